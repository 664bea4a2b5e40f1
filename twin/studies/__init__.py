"""Studies: design-of-experiment runs over scenarios, local or on a Dask cluster (:mod:`~twin.studies.doe`
gathers the public names; responses are a registry, :mod:`~twin.studies.responses`)."""
