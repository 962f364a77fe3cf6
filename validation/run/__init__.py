"""Running a validation matrix: every (case, engine) task on a process pool or a Dask cluster
(:mod:`.executors`), each result stored in the run folder as it finishes (:mod:`.runner`)."""
