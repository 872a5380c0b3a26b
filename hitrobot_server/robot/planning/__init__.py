"""Planning on a grid map, below both robot backends: the grid and its geometry, the costmap
(inflation, virtual walls and tracks, regions), A* with smoothing, a move's options as a search,
and scan matching. The simulator plans its moves and localizes with it; the REST client plans
``compute_path`` with it on a costmap of the robot's map, and the nodes check a relocalization
guess of any robot with it. It imports neither ``sim/`` nor ``rest/``."""
