"""riverflow.engine."""
