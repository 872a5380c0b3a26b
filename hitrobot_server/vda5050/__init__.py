"""VDA 5050 2.0.0: each robot a vehicle that a master control drives over MQTT.

The core is sans-I/O (``schemas``, ``inbox``, ``orders``, ``messages``); ``vehicle`` carries an
order out on the bus; ``mqtt`` is the thin aiomqtt transport (the ``[vda5050]`` extra).
"""
