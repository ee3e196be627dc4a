"""riverflow.systems."""
