"""The model: a validated scenario, its effects composed and simulated into a dataset.

``scenario`` (YAML → validated sections: ``sections``, ``plan``), ``simulate`` (program → thermal chain → effects →
sensor), ``dataset`` (the self-describing HDF5 layout).
"""
