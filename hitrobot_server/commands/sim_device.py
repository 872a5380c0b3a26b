"""``hitrobot-server sim-device``: the built-in simulator served over the Slamware REST API
(:class:`~hitrobot_server.robot.device.SimDevice`) until terminated."""

from __future__ import annotations

import argparse
import sys

from ..robot.device import NOT_EMULATED, SimDevice
from ..robot.factory import build_simulator
from ..robot.options import RobotOptions
from ..signals import until_terminated
from . import run_command


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="hitrobot-server sim-device",
        description="Serve the built-in simulated robot over the Slamware REST API, so "
        "'hitrobot-server --robot http://ADDRESS:PORT' (or any Slamware REST client) can "
        f"drive it. Not emulated: {NOT_EMULATED}.",
    )
    parser.add_argument("--port", type=int, default=1448,
                        help="HTTP port (default: 1448, the robot's; 0 = any free one)")
    parser.add_argument("--address", default="127.0.0.1",
                        help="address to bind (default: 127.0.0.1)")
    robot = RobotOptions()  # the server's defaults for a simulated robot
    parser.add_argument("--world", metavar="FILE", default=robot.world,
                        help="map_server YAML (+ PGM) to drive in (default: the built-in office)")
    parser.add_argument("--sim-speed", type=float, default=robot.sim_speed,
                        help="simulated seconds per wall-clock second "
                        f"(default: {robot.sim_speed:g})")
    parser.add_argument("--sim-seed", type=int, default=robot.sim_seed,
                        help=f"random seed of the simulator (default: {robot.sim_seed})")
    parser.add_argument("--sim-mapping", action="store_true", default=robot.sim_mapping,
                        help="start with an empty map and mapping on")
    parser.add_argument("--log-level", default="info",
                        help="logging level: debug, info, warning, error (default: info)")
    return parser


async def serve(args: argparse.Namespace) -> None:
    simulator = build_simulator(args.world, args.sim_seed, args.sim_mapping)
    device = SimDevice(simulator, address=args.address, port=args.port,
                       time_scale=args.sim_speed)
    await device.start()
    print(f"hitrobot-server sim-device: {device.url}", flush=True)
    try:
        await until_terminated()
    finally:
        await device.stop()


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.sim_speed <= 0:
        print("hitrobot-server sim-device: --sim-speed must be positive", file=sys.stderr)
        return 2
    return run_command("hitrobot-server sim-device", lambda: serve(args), args.log_level)


if __name__ == "__main__":
    sys.exit(main())
