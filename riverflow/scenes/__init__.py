"""riverflow.scenes."""
