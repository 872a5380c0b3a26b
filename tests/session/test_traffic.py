"""The per-topic counts behind /metrics stay bounded when clients use ever new topic names
(a soak over months: one entry per name would grow without end)."""

from __future__ import annotations

from hitrobot_server.session.traffic import MAX_TOPICS, OTHER_TOPICS, Traffic, counts_of


def test_topics_past_the_limit_are_counted_together():
    traffic = Traffic(limit=3)
    for n in range(10):
        traffic.count_sent(f"/client_{n}/cmd", 100)
        traffic.count_thinned(f"/client_{n}/cmd")
    traffic.count_sent("/client_0/cmd", 5)  # a topic counted by name keeps its own count
    assert len(traffic.sent) == len(traffic.thinned) == 3 + 1  # 3 by name, the others
    assert traffic.sent["/client_0/cmd"] == [2, 105]
    assert traffic.sent[OTHER_TOPICS] == [7, 700]  # nothing lost: 10 + 1 messages in all
    assert traffic.thinned[OTHER_TOPICS] == [7]
    assert sum(n for n, _ in traffic.sent.values()) == 11


def test_the_default_bound_holds_for_many_names():
    table: dict = {}
    for n in range(MAX_TOPICS * 3):
        counts_of(table, f"/t{n}", lambda: [0])[0] += 1
    assert len(table) == MAX_TOPICS + 1
    assert table[OTHER_TOPICS] == [MAX_TOPICS * 2]
