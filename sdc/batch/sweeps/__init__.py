"""Many runs into a directory that survives any interruption: a sweep's plan run
(:mod:`sdc.batch.sweeps.sweep_runner`), or grown batch by batch for a search or an
estimate (:mod:`sdc.batch.sweeps.adaptive_runner`); the warm states before the runs,
the manifest, the result store, the progress shown, and a recorded run's replay
checked."""
