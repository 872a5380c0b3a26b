"""A third wire protocol, test-only: a client subscribes with a text line and gets every
message of the topic as one text line. It shows that a protocol is its own package (its
session, its key of the message's memo) plus one ``WireProtocols.register`` line: nothing of
wire/ or of the other sessions changes for it."""
