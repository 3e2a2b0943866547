"""FMI 2.0 export of surrogate elements: :func:`export_fmu` (see :mod:`surrogates.fmi.export`)."""

from surrogates.fmi.export import FMUExportError, export_fmu

__all__ = ["FMUExportError", "export_fmu"]
