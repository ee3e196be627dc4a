"""riverflow.components."""
