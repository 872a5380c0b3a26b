"""Planning on a grid map, below both robot backends: the grid and its geometry, the costmap
(inflation, virtual walls and tracks, regions), A* with smoothing, and a move's options as a
search. The simulator plans its moves with it; the REST client plans ``compute_path`` with it
on a costmap of the robot's map. It imports neither ``sim/`` nor ``rest/``."""
