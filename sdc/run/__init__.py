"""One run: the episode loop (the car in a world backend), its trace and its result row."""
