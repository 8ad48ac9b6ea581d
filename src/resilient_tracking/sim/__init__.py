"""Simulation: the episode loop joining world and team, recording its run tables, and soak runs."""
