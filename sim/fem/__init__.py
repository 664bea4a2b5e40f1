"""Thermoelastic finite elements (scikit-fem) of the die, its package and the comb anchored on it.

``mesh`` builds layered quadrilateral meshes in code, ``elasticity`` assembles linear
thermoelasticity (plane strain, plane stress or generalised plane strain) with one unit thermal
load per material, ``materials_data`` holds the package materials with their sources,
``package_stack`` solves a package cross-section, ``comb_on_substrate`` carries the comb's anchors
on the solved substrate field to an offset [mg] and a scale-factor change [ppm].
User and design notes: ``docs/fem.md``.
"""
