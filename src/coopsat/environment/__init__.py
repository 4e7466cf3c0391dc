"""Environment: disturbance torques and forces acting on the spacecraft (in-loop parts)."""
