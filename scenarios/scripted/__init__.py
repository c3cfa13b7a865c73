"""The scripted world backend: a world without a simulator."""
