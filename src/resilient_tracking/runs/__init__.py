"""Run tables and run folders: the declaration of every table (:mod:`.schema`), the per-step
metrics they record (:mod:`.metrics`), the team's and truth's recorders, writing
(:mod:`.records`, :mod:`.folders`), reading and checking stored runs (:mod:`.reading`), and the
fingerprints that prove results unchanged (:mod:`.fingerprints`)."""
