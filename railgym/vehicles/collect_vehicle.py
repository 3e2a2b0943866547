"""Deprecated path of :mod:`railgym.vehicles.vehicle.collect` (``python -m
railgym.vehicles.collect_vehicle`` still runs it); kept for one version."""

from railgym.vehicles.vehicle.collect import (
    VEHICLE_DEGREES,
    VEHICLE_DESIGN,
    VEHICLE_SURROGATE,
    VEHICLE_TAUS,
    VehicleDesign,
    build_vehicle_surrogate,
    collect_vehicle,
    default_vehicle_surrogate,
    main,
)

__all__ = [
    "VEHICLE_DEGREES",
    "VEHICLE_DESIGN",
    "VEHICLE_SURROGATE",
    "VEHICLE_TAUS",
    "VehicleDesign",
    "build_vehicle_surrogate",
    "collect_vehicle",
    "default_vehicle_surrogate",
    "main",
]


if __name__ == "__main__":
    raise SystemExit(main())
