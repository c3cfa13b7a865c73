"""The geometry of a scene: roads, boxes, bodies along lanes, what the car sees, the kernels."""
