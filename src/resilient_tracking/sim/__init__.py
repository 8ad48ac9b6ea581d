"""Simulation: the episode loop joining world and team and recording its run tables, soak runs,
and the fingerprints that prove results unchanged (:mod:`.fingerprints`)."""
