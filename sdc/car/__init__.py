"""The car: vehicle model, sensors, controllers, collision test and the geometry kernels
under them. Sees plain arrays (a Snapshot, a RoadGeometry), never a simulator."""
