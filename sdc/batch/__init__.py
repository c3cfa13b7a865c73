"""Many runs: a run as a task, executors (local processes, Ray) and the files that
travel with their jobs, the sweep directory (plan, manifest, result parts),
progress, and replay checks."""
