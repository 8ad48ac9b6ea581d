"""Run tables and run folders: the declaration of every table (:mod:`.schema`), the per-step
metrics they record (:mod:`.metrics`), the team's and truth's recorders, writing
(:mod:`.records`, :mod:`.folders`), and reading and checking stored runs (:mod:`.reading`)."""
