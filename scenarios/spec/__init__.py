"""What a scenario and a sweep are: the specs, their fields and checks, TOML in and out."""
