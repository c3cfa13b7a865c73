"""Many runs, in three rooms, each importing only the ones below it:

- :mod:`sdc.batch.sweeps`: a sweep, a search or an estimate run into a directory
  (plan, manifest, result parts, resume), the warm states its runs need, progress,
  and replay checks;
- :mod:`sdc.batch.executors`: where tasks run (local processes, Ray), one row per
  task, and what their workers do with a task's files and outputs;
- :mod:`sdc.batch.tasks`: a unit of work, a class per kind (a run, a warm-up, a
  shared world's runs), and the files that travel with it.
"""
