"""The wire floor: what every wire protocol shares of a message as bytes, and knows none of them.

Above the bus, which keeps of a message only its CDR (what its Zenoh link sends) and an opaque
``wire`` slot, and below session/ and record/. ``memo`` keeps a message's encodings by typed
key, made once and shared by every subscriber (each protocol's package owns its keys);
``frames`` is what an outbox holds of them: frames ready, or pending in the worker pool.
"""
