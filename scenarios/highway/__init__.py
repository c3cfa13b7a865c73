"""The highway-env world backend."""
