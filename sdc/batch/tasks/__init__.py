"""A unit of work, in any process: a class per kind (a run, a warm-up, the runs of a
shared world), what every kind offers its executor (:mod:`sdc.batch.tasks.task`), and
the files that travel with a task (its job files, a warm-up's clock)."""
