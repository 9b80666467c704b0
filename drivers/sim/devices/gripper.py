"""One-axis parallel gripper whose fingertips are soft FingerVision gels."""

from __future__ import annotations


class SimGripper:
    """Fingers move at the commanded speed; an object between them stops them once the gel
    squeeze reaches the commanded force (gel stiffness `gel_stiffness` N/m)."""

    def __init__(self, max_width: float = 0.085, width: float | None = None,
                 gel_stiffness: float = 2500.0, max_speed: float = 0.15):
        self.max_width = max_width
        self._width = max_width if width is None else width
        self._target = self._width
        self._speed = 0.05
        self._force = 20.0
        self.gel_stiffness = gel_stiffness
        self.max_speed = max_speed
        self.object_width: float | None = None  # set by the scene when an object is between
        self._blocked = False
        self.fault_text: str | None = None

    def width(self) -> float:
        return self._width

    def move(self, width: float, speed: float = 0.05, force: float = 20.0) -> None:
        self._target = min(max(float(width), 0.0), self.max_width)
        self._speed = min(max(float(speed), 1e-4), self.max_speed)
        self._force = max(float(force), 0.0)
        self._blocked = False

    def is_moving(self) -> bool:
        return not self._blocked and abs(self._target - self._width) > 1e-9

    def object_detected(self) -> bool:
        return self._blocked

    def stop(self) -> None:
        self._target = self._width

    def fault(self) -> str | None:
        return self.fault_text

    def squeeze_force(self) -> float:
        """Normal force the gels press on the object with (N), 0 without contact."""
        if self.object_width is None:
            return 0.0
        return self.gel_stiffness * max(0.0, self.object_width - self._width)

    def step(self, dt: float) -> None:
        if self._blocked and self.object_width is None:
            self._blocked = False  # the object fell out: the fingers close on towards their target, as a Robotiq's do
        if not self.is_moving():
            return
        delta = self._target - self._width
        step = min(abs(delta), self._speed * dt)
        self._width += step if delta > 0 else -step
        if delta < 0 and self.object_width is not None and self.squeeze_force() >= self._force:
            # Closing on an object: settle where the squeeze balances the commanded force.
            self._width = self.object_width - self._force / self.gel_stiffness
            self._blocked = True
