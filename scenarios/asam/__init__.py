"""ASAM's formats: OpenDRIVE roads read (their reference lines and lanes), OpenSCENARIO
scenarios and parameter distributions read into specs, and runs written out as
OpenSCENARIO with their road as OpenDRIVE."""
