"""The bus joined to other processes over Zenoh, in rmw_zenoh's format (``--bus zenoh``).

What crosses, and how:

* topics (:mod:`.topics`): a local topic with publishers gets a Zenoh publisher and ``MP``
  tokens; one with subscribers gets a Zenoh subscriber and ``MS`` tokens. A local publish is
  CDR-encoded and put only while some other process has a subscriber. Latched topics also
  answer queries on their key with the last message, and a new Zenoh subscriber queries once,
  so late joiners in other processes get it.
* services (:mod:`.services`): a local service is a queryable (``SS``); a call that misses
  locally becomes a get on the provider's key, with the call's timeout; errors travel as reply
  errors with the text.
* actions (:mod:`.actions` serves, :mod:`.remote_actions` calls): ROS 2's shape —
  ``<action>/_action/send_goal``, ``get_result`` and ``cancel_goal`` queryables and the
  ``<action>/_action/feedback`` topic.
* discovery (:mod:`.graph`): liveliness tokens; a process that dies loses its tokens, so it
  leaves rosapi's lists and its proxies fail their calls.

:mod:`.link` composes these into the bus's :class:`~hitrobot_server.bus.link.BusLink`;
:mod:`.peer` is the one Zenoh session they share (this process's tokens, the hop onto the event
loop, queries); :mod:`.keys` is rmw_zenoh's naming. Zenoh calls back on its own threads; every
callback hops onto the event loop first.

This package's own import loads no Zenoh (:mod:`.keys` serves the default bus too, for its
endpoint parsing); import :class:`~.link.ZenohLink` from ``bus.zenoh.link``.
"""
