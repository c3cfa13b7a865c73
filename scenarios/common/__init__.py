"""What every part of the world uses: errors, reading and writing files, the cache, seeds."""
