#!/usr/bin/env python3
"""Fan-out: sensor_msgs/LaserScan (720 ranges) published at max rate to 1/10/50 clients.

Each client count on a fresh hitrobot-server process (``cfg.fanout_reps`` times, the median
kept); ``--compare ARGS`` / ``--compare-tree DIR`` also run a second server, interleaved with the
first, and print the two side by side. bench_ceiling.py runs the same against a bare
``websockets`` server. Prints figures only.

    .venv/bin/python bench/bench_fanout.py --quick --clients 1
    .venv/bin/python bench/bench_fanout.py --quick --compare=--no-send-window
"""

from __future__ import annotations

import asyncio
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from benchlib import (  # noqa: E402  (a sibling script, not a package)
    Config,
    CpuMeter,
    ScanSource,
    ServerProc,
    fnum,
    parser,
    run_main,
    start_ceiling,
    start_ours,
    table,
    verify_scan_samples,
)
from wsclient import RawWs, close_all, perf, warm_up, ws_frame  # noqa: E402


async def open_subscribers(port: int, n_clients: int, count: int, src: ScanSource,
                           topic: str) -> tuple[RawWs, list[RawWs]]:
    """``n_clients`` subscribers (connected in small batches) and a publisher, every
    subscription flowing (warmed up) and the counters zeroed."""
    subs = []
    for k in range(0, n_clients, 25):
        subs += await asyncio.gather(
            *(RawWs.open(port, sample_every=max(count // 10, 1))
              for _ in range(min(25, n_clients - k)))
        )
    pub = await RawWs.open(port)
    pub.send({"op": "advertise", "topic": topic, "type": "sensor_msgs/LaserScan"})
    for s in subs:
        s.send({"op": "subscribe", "topic": topic, "type": "sensor_msgs/LaserScan"})
    await warm_up(pub, src, subs, lambda s: s.count)
    return pub, subs


async def publish_all(pub: RawWs, subs: list[RawWs], count: int, src: ScanSource,
                      cfg: Config) -> tuple[int, float]:
    """Publish as fast as the server takes them (up to ``count`` or ``cfg.fanout_seconds``),
    then wait until every client has all, or nothing arrived for 2 s (the rest was dropped);
    returns (messages sent, time of the last frame received)."""
    sent = 0
    stop_at = perf() + cfg.fanout_seconds
    while sent < count and perf() < stop_at:
        pub.write_frame(ws_frame(src.frame(sent)))
        sent += 1
        await pub.drain()
    t_sent = perf()
    expected = sent * len(subs)
    last_total, last_change = -1, perf()
    while perf() < t_sent + cfg.fanout_timeout:
        total = sum(s.count for s in subs)
        if total >= expected:
            break
        if total != last_total:
            last_total, last_change = total, perf()
        elif perf() - last_change > 2.0 and perf() > t_sent:
            break
        await asyncio.sleep(0.01)
    return sent, max(s.last_rx for s in subs)


async def fanout_run(
    port: int, server: ServerProc, n_clients: int, count: int, src: ScanSource, topic: str,
    cfg: Config,
) -> dict:
    pub, subs = await open_subscribers(port, n_clients, count, src, topic)
    with CpuMeter(server) as cpu:
        t0 = perf()
        sent, t_end = await publish_all(pub, subs, count, src, cfg)
    elapsed = t_end - t0
    counts = [s.count for s in subs]
    total = sum(counts)
    nbytes = sum(s.nbytes for s in subs)
    checked, bad, _ = verify_scan_samples(subs, topic, 10**9)
    await close_all([pub, *subs])
    ok = elapsed > 0
    return {
        "clients": n_clients,
        "count": sent,
        "expected": sent * n_clients,
        "total": total,
        "min": min(counts),
        "max": max(counts),
        "elapsed": elapsed,
        "rate": total / elapsed if ok else float("nan"),
        "per_client": total / elapsed / n_clients if ok else float("nan"),
        "mbps": nbytes / elapsed / 1e6 if ok else float("nan"),
        "frame": nbytes / total if total else float("nan"),
        "checked": checked,
        "bad": bad,
        "cpu": cpu.pcts(elapsed),
        "srv_us": 1e6 * cpu.server_s / total if total else float("nan"),
    }


def fanout_table(title: str, runs: list[dict]) -> None:
    print(title)
    rows = []
    for r in runs:
        rows.append(
            [
                r["clients"],
                f"{r['count']:,}",
                f"{r['total']:,}/{r['expected']:,}",
                f"{r['min']:,}-{r['max']:,}",
                f"{r['expected'] - r['total']:,}",
                f"{r['elapsed']:.2f}",
                fnum(r["rate"]),
                r["range"],
                fnum(r["per_client"]),
                fnum(r["mbps"], 1),
                f"{r['checked'] - r['bad']}/{r['checked']}",
                *r["cpu"],
                f"{r['srv_us']:.1f}",
            ]
        )
    print(
        table(
            [
                "clients",
                "msgs",
                "recv/expected",
                "per client",
                "dropped",
                "s",
                "msg/s total",
                "range of runs",
                "msg/s/client",
                "MB/s",
                "samples ok",
                "srv CPU",
                "cli CPU",
                "srv us/msg",
            ],
            rows,
        )
    )


class Variant:
    """One server under test in section 2/4: ours (with ``extra`` flags, from ``tree``) or the
    ceiling."""

    def __init__(self, label: str, ceiling: bool = False, extra: tuple = (),
                 tree: str | None = None):
        self.label, self.ceiling, self.extra, self.tree = label, ceiling, tuple(extra), tree

    def start(self, cfg: Config, tag: str) -> ServerProc:
        if self.ceiling:
            return start_ceiling(cfg.ceiling_lib)
        return start_ours(cfg.profile, f"{tag}_{self.label}", self.extra, self.tree)


async def fanout_section(variants: list[Variant], cfg: Config) -> dict[str, list[dict]]:
    """Each client count ``cfg.fanout_reps`` times per variant, each run on a fresh server, the
    variants interleaved (a, b, ..., a, b, ...: a busy machine's load falls on all alike); the
    median run of each is kept."""
    out: dict[str, list[dict]] = {v.label: [] for v in variants}
    for n in cfg.clients:
        topic = f"/bench/scan_{n}"
        src = ScanSource(topic)
        reps: dict[str, list[dict]] = {v.label: [] for v in variants}
        for rep in range(cfg.fanout_reps):
            for v in variants:
                server = v.start(cfg, f"fanout_{n}_{rep}")
                try:
                    reps[v.label].append(await fanout_run(
                        server.port, server, n, cfg.scan_counts[n], src, topic, cfg))
                finally:
                    server.stop()
        for v in variants:
            runs = sorted(reps[v.label], key=lambda r: r["rate"])
            run = dict(runs[len(runs) // 2])
            run["range"] = (f"{fnum(runs[0]['rate'])}-{fnum(runs[-1]['rate'])}"
                            if len(runs) > 1 else "-")
            run["total_all"] = sum(r["total"] for r in runs)
            run["expected_all"] = sum(r["expected"] for r in runs)
            out[v.label].append(run)
    return out


def compare_table(base: str, other: str, a: list[dict], b: list[dict]) -> list[str]:
    """Prints ``other``'s delivered rate against ``base``'s (same run, interleaved); returns
    summary lines."""
    rows, lines = [], []
    for x, y in zip(a, b, strict=True):
        ratio = y["rate"] / x["rate"] if x["rate"] else float("nan")
        rows.append([x["clients"], fnum(x["rate"]), fnum(y["rate"]), f"{ratio:.2f}",
                     f"{x['total_all']:,}/{x['expected_all']:,}",
                     f"{y['total_all']:,}/{y['expected_all']:,}",
                     f"{x['srv_us']:.1f}", f"{y['srv_us']:.1f}"])
        lines.append(f"{other} vs {base}, {x['clients']:>2} clients: {ratio:.2f} "
                     f"({fnum(y['rate'])} vs {fnum(x['rate'])} msg/s; received "
                     f"{y['total_all']:,}/{y['expected_all']:,} vs "
                     f"{x['total_all']:,}/{x['expected_all']:,})")
    print(f"\n  {other} vs {base} (delivered msg/s, all clients; runs interleaved)")
    print(table(["clients", base, other, "ratio", f"{base} received", f"{other} received",
                 f"{base} us/msg", f"{other} us/msg"], rows))
    return lines


def variants(cfg: Config) -> list[Variant]:
    """Ours, and the ``--compare``/``--compare-tree`` server when asked for."""
    out = [Variant("ours")]
    if cfg.compare is not None:
        out.append(Variant(cfg.compare_label, extra=cfg.compare, tree=cfg.compare_tree))
    return out


def report(variants: list[Variant], runs: dict[str, list[dict]], cfg: Config) -> list[str]:
    """Prints section [2] for every server that is not the ceiling; returns summary lines."""
    ours = runs["ours"]
    size = ours[0]["frame"]
    for v in variants:
        if not v.ceiling:
            fanout_table(
                f"\n[2] fan-out: sensor_msgs/LaserScan, 720 float ranges (~{size / 1e3:.1f} "
                f"kB frames) published at max rate, hitrobot-server ({v.label})",
                runs[v.label],
            )
    print(
        "  msg/s = frames received by all clients / (last frame received - first publish "
        "sent); MB/s = payload bytes, all clients.\n  dropped = expected - received (a "
        "slow client loses its oldest topic data by design); per client = min-max "
        "received.\n  "
        + (f"median of {cfg.fanout_reps} runs, each on a fresh server "
           "process; 'range of runs' = slowest-fastest."
           if cfg.fanout_reps > 1 else "one run per client count.")
    )
    lines = [
        f"fan-out {r['clients']:>2} clients: {fnum(r['rate'])} msg/s total, "
        f"{fnum(r['per_client'])}/client, {fnum(r['mbps'], 1)} MB/s, "
        f"received {r['total_all']:,}/{r['expected_all']:,} (all runs)"
        for r in ours
    ]
    if cfg.compare is not None:
        lines += compare_table("ours", cfg.compare_label, ours, runs[cfg.compare_label])
    return lines


async def scenario(cfg: Config) -> list[str]:
    """Section [2] (and the comparison, when asked for); returns its summary lines."""
    servers = variants(cfg)
    return report(servers, await fanout_section(servers, cfg), cfg)


if __name__ == "__main__":
    sys.exit(run_main(parser(__doc__.split("\n\n")[0], fanout=True).parse_args(), scenario))
