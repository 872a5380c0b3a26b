"""The recorder's hand-off to its writer: frames down a real pipe, written by the event loop
without blocking, read back whole and in order with ``Connection.recv_bytes`` (the writer's
side), even when the pipe is full and the rest waits for the loop."""

from __future__ import annotations

import asyncio
import multiprocessing
import os
import threading

from hitrobot_server.record.recorder import PipeFeed


def test_frames_bigger_than_the_pipe_arrive_whole_and_in_order():
    reading, writing = multiprocessing.Pipe(duplex=False)
    payloads = [os.urandom(n) for n in (10, 300_000, 1, 2_000_000, 65_536, 0, 123_457)]
    got: list[bytes] = []

    def reader() -> None:  # the writer process's side, as a thread here
        for _ in payloads:
            got.append(reading.recv_bytes())

    async def main() -> bool:
        feed = PipeFeed(writing, asyncio.get_running_loop())
        for k, payload in enumerate(payloads):  # never blocks: the rest waits in the feed
            if k % 2:
                feed.send(payload)
            else:  # a frame in parts (a batch's headers and messages), never joined
                third = len(payload) // 3
                feed.send(payload[:third], b"", payload[third:2 * third], payload[2 * third:])
        pending = feed.waiting > 0
        thread = threading.Thread(target=reader)
        thread.start()
        await asyncio.wait_for(feed.drain(lambda: True), 10.0)
        await asyncio.to_thread(thread.join, 10.0)
        feed.close()
        return pending

    assert asyncio.run(main()), "3.5 MB is more than a pipe holds: some had to wait"
    assert got == payloads
    reading.close()


def test_a_gone_reader_breaks_the_feed_and_loses_nothing_else():
    reading, writing = multiprocessing.Pipe(duplex=False)
    reading.close()  # the writer process died

    async def main() -> PipeFeed:
        feed = PipeFeed(writing, asyncio.get_running_loop())
        feed.send(b"batch", b"1")
        feed.send(b"more")  # dropped quietly: nobody reads
        await asyncio.wait_for(feed.drain(lambda: True), 5.0)
        feed.close()
        return feed

    assert asyncio.run(main()).broken


def test_without_a_loop_it_writes_at_once():
    reading, writing = multiprocessing.Pipe(duplex=False)
    feed = PipeFeed(writing, None)
    feed.send(b"x" * 1000)
    assert reading.recv_bytes() == b"x" * 1000
    feed.close()
    reading.close()
