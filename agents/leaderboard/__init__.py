"""The benchmark leaderboard of the tasks of :mod:`railgym.tasks`: evaluation on the cases
(:mod:`~agents.leaderboard.cases`), bounds (:mod:`~agents.leaderboard.bounds`), IQM statistics
(:mod:`~agents.leaderboard.stats`), entries and table (:mod:`~agents.leaderboard.results`),
entries from runs (:mod:`~agents.leaderboard.run`), pages (:mod:`~agents.leaderboard.docs`) and
the command ``railgym leaderboard`` (:mod:`agents.commands.leaderboard`)."""
