"""GearMesh's independent nonlinear FE reference of a spur pair (CalculiX), reference_fe/README.md.

Shares no code with core/, compliance_tool/ or python/gearmesh/: an independent check."""
