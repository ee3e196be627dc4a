"""riverflow.hydro."""
