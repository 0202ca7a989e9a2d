"""fmpy tooling for the GearMesh gear-contact FMU: scenes, runs, reports."""

__version__ = "0.1.0"
