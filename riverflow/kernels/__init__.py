"""riverflow.kernels."""
