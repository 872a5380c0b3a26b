"""Names of nodes and interfaces that other nodes address on the bus (a name, never the node's
module): the one place a node spells a name another node serves."""

MAP_MANAGER = "/map_manager"
MAP_MANAGER_GET_POIS = f"{MAP_MANAGER}/get_pois"
"""The map manager's POIs (``map_messages/GetPointsOfInterest``): how other nodes read them."""
MAP_MANAGER_SAVE_MAP = f"{MAP_MANAGER}/save_map"
MAP_MANAGER_LOAD_MAP = f"{MAP_MANAGER}/load_map"
MAP_MANAGER_LOADED_MAP = f"{MAP_MANAGER}/loaded_map"
"""Latched std_msgs/String: the saved map last loaded ("" for none), kept across restarts."""
"""The map manager's map-folder requests (``map_messages/SaveMap``): the shell's map commands
and the map-files node's ``load_laser_map`` ask it on a client's behalf."""

SLAMWARE_NODE = "/slamware_ros_sdk_server_node"
"""The Slamware node's name: its relative topic names live under it."""
SLAMWARE_SYNC_MAP = f"{SLAMWARE_NODE}/sync_map"
SLAMWARE_CLEAR_MAP = f"{SLAMWARE_NODE}/clear_map"
"""Clears the robot's map (``slamware_ros_sdk/ClearMapRequest``); the map manager hears its
success (``SLAMWARE_MAP_CLEARED`` in the Slamware node's reply): no saved map is loaded then."""
SLAMWARE_MAP_CLEARED = "the map was cleared"
"""Asks the Slamware node to read the robot's whole map again (after the map manager replaced
it)."""
MAP_TOPIC = "/map"
"""The map manager's composed map, made of the robot's: read by a client, it keeps the
Slamware node's map copy at its full rate."""

TF = "/tf"
TF_STATIC = "/tf_static"

COMPUTE_PATH = "/compute_path_to_pose"
FOLLOW_PATH = "/follow_path"
"""The Nav2 actions of a robot (under ``/NAME/`` for a named one): the fleet plans a task with
the first and drives it with the second."""

FLEET_MEMBERS = "/fleet/members"
"""Each named robot's state (``hitrobot_msgs/FleetRobot``), heard by the site's fleet node."""

VDA5050_LINK = "/vda5050/link"
"""Every robot's VDA 5050 link (``hitrobot_msgs/VdaLinks``, latched): the fleet marks a robot
running a master control's order busy, the console shows it."""
FLEET_ROBOTS = "/fleet/robots"
"""The fleet's robots (``hitrobot_msgs/FleetRobots``): a VDA 5050 vehicle refuses an order
while its robot runs a fleet task."""
