"""Models shared by truth and belief: the sensor, the target motion model, graph helpers,
lengths.

Both ``world`` (to simulate) and ``belief`` (to estimate) use these; neither owns them.
"""
