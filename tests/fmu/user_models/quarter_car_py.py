"""A quarter car as a user would bring it: a pythonfmu (0.7.0) co-simulation slave.

Written without any railgym code; the same model as ``quarter_car.c`` (same variables,
value references, parameters and integration), so the two FMUs give the same trajectories.

Bodies (displacements from the loaded static equilibrium, m, positive upwards; gravity is
balanced by the static preload of the secondary spring): bogie ``x1, v1`` (m1 = 1 800 kg),
carbody ``x2, v2`` (m2 = 8 000 kg). Primary: ``k1 (zr - x1) + c1 (zr_dot - v1)``. Secondary
(no bump stops, ``δ = x1 − x2`` > 0 in compression): ``k2 δ (1 + 30 δ²) + c(δ̇) δ̇`` with
``c`` blended from 1.4e4 N·s/m (rebound) to 2.0e4 N·s/m (compression) by
``(1 + tanh(δ̇ / 0.01)) / 2``. ``Fact`` (N) acts upwards on the carbody, downwards on the
bogie. ``do_step`` integrates with classic RK4 in 4 substeps, the inputs held over the
communication step. pythonfmu 0.7.0 declares no units: all variables are SI.

Build: ``pythonfmu build -f quarter_car_py.py -d <folder>`` (gives ``QuarterCar.fmu``).
"""

import math

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real  # type: ignore[import-untyped, unused-ignore]

M1 = 1800.0  # kg
M2 = 8000.0  # kg
K1 = 2.4e6  # N/m
C1 = 3.0e4  # N s/m
K2 = 4.3e5  # N/m
PROGRESSION = 30.0  # 1/m^2
C_COMP = 2.0e4  # N s/m
C_REB = 1.4e4  # N s/m
V_BLEND = 0.01  # m/s
N_SUBSTEPS = 4


def secondary_force(delta: float, delta_dot: float) -> float:
    """Secondary force (N, compression positive) at deflection ``delta`` (m) and its rate
    ``delta_dot`` (m/s)."""
    w = 0.5 * (1.0 + math.tanh(delta_dot / V_BLEND))
    c = C_REB + (C_COMP - C_REB) * w
    return K2 * delta * (1.0 + PROGRESSION * delta * delta) + c * delta_dot


def rates(x: list[float], zr: float, zr_dot: float, fact: float) -> list[float]:
    """State derivative of ``x = [x1, v1, x2, v2]``."""
    fs = secondary_force(x[0] - x[2], x[1] - x[3])
    f1 = K1 * (zr - x[0]) + C1 * (zr_dot - x[1])
    return [x[1], (f1 - fs - fact) / M1, x[3], (fs + fact) / M2]


class QuarterCar(Fmi2Slave):
    """Quarter car with a nonlinear secondary suspension (module docstring)."""

    author = "a railgym user (test model)"
    description = "Quarter car, nonlinear secondary without bump stops (pythonfmu)"

    def __init__(self, **kwargs: object) -> None:
        super().__init__(**kwargs)
        self.zr = 0.0
        self.zr_dot = 0.0
        self.Fact = 0.0
        self.x1 = 0.0
        self.v1 = 0.0
        self.x2 = 0.0
        self.v2 = 0.0
        cont = Fmi2Variability.continuous
        for name, text in (
            ("zr", "track displacement, m"),
            ("zr_dot", "track displacement rate, m/s"),
            ("Fact", "actuator force, N, upwards on the carbody"),
        ):
            self.register_variable(
                Real(name, causality=Fmi2Causality.input, variability=cont, description=text)
            )
        for name, text in (
            ("x1", "bogie displacement, m"),
            ("v1", "bogie velocity, m/s"),
            ("x2", "carbody displacement, m"),
            ("v2", "carbody velocity, m/s"),
        ):
            self.register_variable(
                Real(name, causality=Fmi2Causality.output, variability=cont, description=text)
            )
        self.register_variable(
            Real(
                "a2",
                causality=Fmi2Causality.output,
                variability=cont,
                description="carbody acceleration, m/s2",
                getter=self.carbody_acceleration,
            )
        )

    def carbody_acceleration(self) -> float:
        """``a2`` (m/s²) from the current state and actuator force."""
        fs = secondary_force(self.x1 - self.x2, self.v1 - self.v2)
        return (fs + self.Fact) / M2

    def do_step(self, current_time: float, step_size: float) -> bool:
        h = step_size / N_SUBSTEPS
        u = (self.zr, self.zr_dot, self.Fact)  # held over the step
        x = [self.x1, self.v1, self.x2, self.v2]
        for _ in range(N_SUBSTEPS):
            k1 = rates(x, *u)
            k2 = rates([xi + 0.5 * h * ki for xi, ki in zip(x, k1, strict=True)], *u)
            k3 = rates([xi + 0.5 * h * ki for xi, ki in zip(x, k2, strict=True)], *u)
            k4 = rates([xi + h * ki for xi, ki in zip(x, k3, strict=True)], *u)
            x = [
                xi + h / 6.0 * (a + 2.0 * b + 2.0 * c + d)
                for xi, a, b, c, d in zip(x, k1, k2, k3, k4, strict=True)
            ]
        self.x1, self.v1, self.x2, self.v2 = x
        return True
