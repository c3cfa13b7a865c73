"""Many runs: a run as a task, executors (local processes, Ray), the sweep directory
(plan, manifest, result parts), progress, and replay checks."""
