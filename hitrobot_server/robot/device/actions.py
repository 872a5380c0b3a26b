"""The sim-device's action endpoints: actions started from their JSON (the factories the robot
lists), the current one, one by id (a finished one as a gravestone), the path ahead, speed."""

from __future__ import annotations

from typing import Any

from aiohttp import web

from ..backend import ACTION_PREFIX, BackendError
from ..model import ActionDirection, ActionInfo
from ..rest import paths, shapes
from ..sim.backend import SimBackend
from .replies import body_of, empty, getter, reply, text

ACTION_NAMES = ("MoveToAction", "SeriesMoveToAction", "MoveByAction", "RotateToAction",
                "RotateAction", "GoHomeAction", "RecoverLocalizationAction")


class ActionRoutes:
    """Starting, following and cancelling the robot's actions."""

    def __init__(self, backend: SimBackend) -> None:
        self.backend = backend

    def add_to(self, router: web.UrlDispatcher) -> None:
        b = self.backend
        get = router.add_get
        get(paths.ACTION_FACTORIES, self._factories, allow_head=False)
        router.add_post(paths.ACTIONS, self._create_action)
        get(paths.CURRENT_ACTION, self._current_action, allow_head=False)
        router.add_delete(paths.CURRENT_ACTION, self._cancel_action)
        get(paths.ACTIONS + r"/{action_id:\d+}", self._action, allow_head=False)
        get(paths.PATH, getter(b.motion.get_remaining_path, shapes.path_json), allow_head=False)
        get(paths.MILESTONES, getter(b.motion.get_remaining_milestones, shapes.path_json),
            allow_head=False)
        get(paths.SPEED, self._speed, allow_head=False)

    async def _factories(self, request: web.Request) -> web.Response:
        return reply([{"action_name": ACTION_PREFIX + name} for name in ACTION_NAMES])

    async def _create_action(self, request: web.Request) -> web.Response:
        try:
            body = shapes.obj(await body_of(request), "body")
            info = await self._start(body)
        except (BackendError, ValueError) as exc:
            return text(400, f"Can not create action: {exc}")
        return reply(shapes.action_json(info))

    async def _start(self, body: Any) -> ActionInfo:
        name = body.get("action_name")
        options = shapes.obj(body.get("options") or {}, "options")
        short = name.removeprefix(ACTION_PREFIX) if isinstance(name, str) else ""
        if not isinstance(name, str) or not name.startswith(ACTION_PREFIX) \
                or short not in ACTION_NAMES:
            raise shapes.ShapeError(f"unknown action {name!r}")
        move, yaw = shapes.move_options_from(options.get("move_options"))
        if short in ("MoveToAction", "SeriesMoveToAction"):
            return await self._move_to(short, options, move, yaw)
        if short == "MoveByAction":
            return await self._move_by(options, move)
        if short in ("RotateToAction", "RotateAction"):
            angle = shapes.number(options.get("angle"), "angle")
            if short == "RotateToAction":
                return await self.backend.motion.rotate_to(angle, move)
            return await self.backend.motion.rotate(angle, move)
        if short == "GoHomeAction":
            home = shapes.obj(options.get("gohome_options") or {}, "gohome_options")
            move, _ = shapes.move_options_from(home.get("move_options"))
            return await self.backend.motion.go_home(move)
        return await self._recover(options)

    async def _move_to(self, short: str, options: dict, move, yaw: float) -> ActionInfo:
        if short == "MoveToAction":
            return await self.backend.motion.move_to(
                [shapes.point_from(options.get("target"), "target")], move, yaw)
        raw = shapes.array(options.get("targets"), "targets")
        if not raw:
            raise shapes.ShapeError("targets must not be empty")
        targets = [shapes.point_from(t, f"targets[{i}]") for i, t in enumerate(raw)]
        return await self.backend.motion.move_to(targets, move, yaw)

    async def _move_by(self, options: dict, move) -> ActionInfo:
        duration = shapes.number(options.get("duration", 500), "duration") / 1000.0
        if "direction" in options:
            raw_direction = shapes.integer(options["direction"], "direction")
            try:
                direction = ActionDirection(raw_direction)
            except ValueError:
                raise shapes.ShapeError(f"direction must be 0-3, got {raw_direction}") \
                    from None
            return await self.backend.motion.move_by_direction(direction, move, duration)
        if "theta" in options:
            theta = shapes.number(options["theta"], "theta")
            return await self.backend.motion.move_by_theta(theta, move, duration)
        raise shapes.ShapeError("MoveByAction needs a direction or a theta")

    async def _recover(self, options: dict) -> ActionInfo:
        """RecoverLocalizationAction."""
        area = None if options.get("area") is None else shapes.rect_from(options["area"], "area")
        reloc = shapes.obj(options.get("relocalization_options") or {},
                           "relocalization_options")
        max_time = reloc.get("max_recover_time")
        return await self.backend.localization.recover_localization(
            area, None if max_time is None else shapes.integer(max_time, "max_recover_time"),
            shapes.movement_from(reloc.get("recover_movement_type")))

    async def _current_action(self, request: web.Request) -> web.Response:
        action = await self.backend.motion.get_current_action()
        if action is None:
            return text(404, "Action Not Found")
        return reply(shapes.action_json(action))

    async def _cancel_action(self, request: web.Request) -> web.Response:
        await self.backend.motion.cancel_action()
        return empty()

    async def _action(self, request: web.Request) -> web.Response:
        action = await self.backend.motion.get_action(int(request.match_info["action_id"]))
        if action is None:
            return text(404, "Action Not Found")
        data = shapes.action_json(action)
        if action.done:  # a finished action reads back as a gravestone
            data = {"action_id": data["action_id"], "state": data["state"]}
        return reply(data)

    async def _speed(self, request: web.Request) -> web.Response:
        return reply(shapes.speed_json((await self.backend.sensors.get_odometry()).twist))
