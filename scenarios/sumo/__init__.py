"""The SUMO world backend: the simulation, its vehicle types, warm states."""
