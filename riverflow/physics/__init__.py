"""riverflow.physics."""
