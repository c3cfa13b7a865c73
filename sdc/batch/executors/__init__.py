"""Where tasks run: the executors (local processes, Ray; their contract in
:mod:`sdc.batch.executors.executor`), the run timeout, and a task's trip through a
worker (its files copied and checked there, its outputs' bytes back to the driver)."""
