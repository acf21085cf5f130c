"""The control loop and the mechanics of one joint, stepped at a fixed period.

Everything here is at the output shaft in turns, turn/s and Nm. The controller
is ODrive's cascade: an input stage (passthrough, input filter, trapezoid or
S-curve trajectory, speed or torque ramp) makes position, speed and torque
setpoints; ``speed = pos_gain*(pos_sp - pos) + vel_sp`` (clamped to the speed
limit), ``torque = vel_gain*(speed - vel) + integrator + torque_sp`` (clamped to
the torque limit; the integrator decays while clamped). Torque mode applies the
setpoint with the current-mode speed limiter; impedance mode applies
``kp*(pos_sp - pos) + kd*(vel_sp - vel) + torque_sp``.

The mechanics: inertia with viscous and Coulomb friction (the shaft sticks while
the net torque stays below the Coulomb torque). The speed-proportional part of
the controller torque is integrated implicitly, so that large gains stay stable
at the 1 ms step. A :class:`Plant` (a physics model, :mod:`drempower.sim.twin`)
may move the shaft instead: the drive then only computes its torque.
"""

from __future__ import annotations

import math
from typing import Protocol

from .profile import Profile, plan

__all__ = ["Drive", "Plant", "TORQUE", "VELOCITY", "POSITION", "IMPEDANCE"]

TORQUE, VELOCITY, POSITION, IMPEDANCE = 1, 2, 3, 4
"""Control modes (ControlMode values)."""
PASSTHROUGH, VEL_RAMP, POS_FILTER, TRAP_TRAJ, TORQUE_RAMP = 1, 2, 3, 5, 6
"""Input modes (InputMode values)."""

TAU = 2.0 * math.pi


class Plant(Protocol):
    """What moves the output shaft in place of the drive's own mechanics.

    Each step the drive computes ``torque`` (Nm) and ``gain``, the torque's
    derivative with respect to the shaft speed (Nm per turn/s, to integrate
    implicitly); the plant applies them and writes ``pos`` (turns) and ``vel`` (turn/s).
    """

    def sync(self, now: float) -> None:
        """Bring the drives' ``pos`` and ``vel`` up to simulated time ``now`` (s), before their step."""


class Drive:
    """Controller and mechanics state of one joint (output shaft: turns, turn/s, Nm)."""

    __slots__ = (
        "active",
        "b",
        "cm_vlim",
        "ext",
        "fc",
        "g_idle",
        "gain",
        "imp_kd",
        "imp_kp",
        "in_pos",
        "in_tq",
        "in_vel",
        "input_mode",
        "integ",
        "j",
        "jff",
        "ki",
        "kp",
        "kv",
        "lim_on",
        "lmax",
        "lmin",
        "locked",
        "mode",
        "omega",
        "plant",
        "pos",
        "pos_sp",
        "prof_t",
        "profile",
        "tlim",
        "torque",
        "tq_rate",
        "tq_sp",
        "vel",
        "vel_rate",
        "vel_sp",
        "vlim",
    )

    def __init__(self) -> None:
        self.active = False
        """Closed loop (else the motor is unpowered, with optional idle damping)."""
        self.mode = POSITION
        self.input_mode = PASSTHROUGH
        self.pos = self.vel = self.torque = 0.0
        self.pos_sp = self.vel_sp = self.tq_sp = 0.0
        self.in_pos = self.in_vel = self.in_tq = 0.0
        self.integ = 0.0
        self.omega = 20.0
        self.vel_rate = self.tq_rate = 0.0
        self.profile: Profile | None = None
        self.prof_t = 0.0
        self.imp_kp = self.imp_kd = 0.0
        # gains and limits (set by the motor from its parameters)
        self.kp = self.kv = self.ki = 0.0
        self.vlim = self.tlim = math.inf
        self.jff = 0.0
        self.cm_vlim = True
        self.lim_on = False
        self.lmin = -math.inf
        self.lmax = math.inf
        # mechanics
        self.j = 1.0
        self.b = self.fc = self.ext = 0.0
        self.g_idle = 0.0
        """Idle damping (Nm per turn/s) applied while not in closed loop."""
        self.locked = False
        self.plant: Plant | None = None
        """Moves the shaft instead of the mechanics below (None: the drive's own)."""
        self.gain = 0.0
        """The last step's torque derivative with respect to speed (Nm per turn/s), for a plant."""

    # ------------------------------------------------------------------ commands

    def _position_setpoints(self) -> None:
        """Start a position input stage from the current setpoint, or from the shaft if none."""
        if self.mode != POSITION:
            self.pos_sp, self.vel_sp = self.pos, self.vel
            self.mode = POSITION
        self.tq_sp = 0.0

    def hold(self, pos: float) -> None:
        """Hold ``pos`` (position passthrough, no feed-forward)."""
        self.mode, self.input_mode = POSITION, PASSTHROUGH
        self.pos_sp = self.in_pos = pos
        self.vel_sp = self.in_vel = self.tq_sp = self.in_tq = 0.0
        self.profile = None

    def position(self, pos: float, vel_ff: float, torque_ff: float) -> None:
        """Position passthrough with speed and torque feed-forward (P mode)."""
        self.hold(pos)
        self.vel_sp = self.in_vel = vel_ff
        self.tq_sp = self.in_tq = torque_ff

    def filtered(self, pos: float, omega: float) -> None:
        """Track ``pos`` through the critically damped 2nd-order filter of bandwidth ``omega`` 1/s (T mode)."""
        self._position_setpoints()
        self.input_mode = POS_FILTER
        self.in_pos, self.omega = pos, omega
        self.profile = None

    def trajectory(self, target: float, vmax: float, accel: float, s_curve: bool) -> Profile:
        """Follow a trapezoid or S-curve profile to ``target`` (Q mode); returns the plan."""
        self._position_setpoints()
        self.input_mode = TRAP_TRAJ
        self.in_pos = target
        self.profile = prof = plan(self.pos_sp, self.vel_sp, target, vmax, accel, s_curve)
        self.prof_t = 0.0
        return prof

    def velocity(self, vel: float, torque_ff: float, ramp: float | None) -> None:
        """Run at ``vel``: passthrough with torque feed-forward, or ramped at ``ramp`` turn/s^2 (V mode)."""
        if self.mode != VELOCITY:
            self.vel_sp = self.vel
            self.mode = VELOCITY
        self.in_vel, self.in_tq = vel, torque_ff
        self.profile = None
        if ramp is None:
            self.input_mode = PASSTHROUGH
            self.vel_sp, self.tq_sp = vel, torque_ff
        else:
            self.input_mode, self.vel_rate = VEL_RAMP, ramp

    def torque_command(self, torque: float, ramp: float | None) -> None:
        """Apply ``torque`` Nm at once, or ramped at ``ramp`` Nm/s (C mode)."""
        if self.mode != TORQUE:
            self.tq_sp = self.torque
            self.mode = TORQUE
        self.integ = 0.0
        self.in_tq = torque
        self.profile = None
        if ramp is None:
            self.input_mode, self.tq_sp = PASSTHROUGH, torque
        else:
            self.input_mode, self.tq_rate = TORQUE_RAMP, ramp

    def impedance(self, pos: float, vel: float, torque_ff: float, kp: float, kd: float) -> None:
        """Impedance control: ``kp`` Nm/turn, ``kd`` Nm/(turn/s) around ``pos``, ``vel``, plus ``torque_ff``."""
        self.mode, self.input_mode = IMPEDANCE, PASSTHROUGH
        self.pos_sp = self.in_pos = pos
        self.vel_sp = self.in_vel = vel
        self.tq_sp = self.in_tq = torque_ff
        self.imp_kp, self.imp_kd = kp, kd
        self.integ = 0.0
        self.profile = None

    def trajectory_done(self) -> bool:
        """Whether the current Q profile has ended (True when there is none)."""
        prof = self.profile
        return prof is None or self.prof_t >= prof.duration

    # ------------------------------------------------------------------ stepping

    def step(self, dt: float) -> None:
        """Advance the controller and the mechanics by ``dt`` seconds."""
        vel = self.vel
        if self.active:
            im = self.input_mode
            if im == TRAP_TRAJ:
                self.prof_t += dt
                self.pos_sp, self.vel_sp, acc = self.profile.sample(self.prof_t)  # type: ignore[union-attr]
                self.tq_sp = acc * self.jff
            elif im == POS_FILTER:
                w = self.omega
                acc = w * w * (self.in_pos - self.pos_sp) - 2.0 * w * self.vel_sp
                self.vel_sp += acc * dt
                self.pos_sp += self.vel_sp * dt
                self.tq_sp = acc * self.jff
            elif im == VEL_RAMP:
                lim = self.vel_rate * dt
                dv = self.in_vel - self.vel_sp
                dv = lim if dv > lim else -lim if dv < -lim else dv
                self.vel_sp += dv
                self.tq_sp = dv / dt * self.jff
            elif im == TORQUE_RAMP:
                lim = self.tq_rate * dt
                dq = self.in_tq - self.tq_sp
                self.tq_sp += lim if dq > lim else -lim if dq < -lim else dq
            mode = self.mode
            tlim = self.tlim
            if mode == TORQUE:
                tq = self.tq_sp
                g = 0.0
                if self.cm_vlim:
                    kv, vlim = self.kv, self.vlim
                    hi, lo = (vlim - vel) * kv, (-vlim - vel) * kv
                    if tq > hi:
                        tq, g = hi, kv
                    elif tq < lo:
                        tq, g = lo, kv
            elif mode == IMPEDANCE:
                g = self.imp_kd
                tq = self.imp_kp * (self.pos_sp - self.pos) + g * (self.vel_sp - vel) + self.tq_sp
            else:
                vdes = self.vel_sp
                if mode == POSITION:
                    vdes += self.kp * (self.pos_sp - self.pos)
                vlim = self.vlim
                if vdes > vlim:
                    vdes = vlim
                elif vdes < -vlim:
                    vdes = -vlim
                verr = vdes - vel
                g = self.kv
                tq = g * verr + self.integ + self.tq_sp
                if -tlim <= tq <= tlim:
                    self.integ += self.ki * dt * verr
                else:
                    self.integ *= 0.99
            if tq > tlim:
                tq, g = tlim, 0.0
            elif tq < -tlim:
                tq, g = -tlim, 0.0
            if (
                self.lim_on
                and mode != POSITION
                and ((self.pos >= self.lmax and vel > 0.0) or (self.pos <= self.lmin and vel < 0.0))
            ):
                self.hold(self.lmax if vel > 0.0 else self.lmin)
        else:
            g = self.g_idle
            tq = -g * vel
        self.torque = tq
        if self.plant is not None:
            self.gain = g
            return
        if self.locked:
            self.vel = 0.0
            return
        fc = self.fc
        net = tq + self.ext - self.b * vel
        k = dt / (self.j + (g + self.b) * dt)
        if vel == 0.0:
            if net > fc:
                nv = (net - fc) * k
            elif net < -fc:
                nv = (net + fc) * k
            else:
                return
        else:
            nv = vel + (net - fc if vel > 0.0 else net + fc) * k
            if vel * nv < 0.0:
                nv = 0.0
        self.pos += (vel + nv) * 0.5 * dt
        self.vel = nv
