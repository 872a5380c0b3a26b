"""The wire floor: a bus message or a reply as the bytes a client gets.

Above the bus, which keeps of a message only its CDR (what its Zenoh link sends) and an opaque
``wire`` slot, and below session/ and record/. ``encoded`` keeps a message's encodings, made
once and shared by every subscriber; ``frames`` is the one builder of frames (JSON, png,
fragments) for published messages and replies alike.
"""
