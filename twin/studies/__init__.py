"""Studies: design-of-experiment runs over scenarios, local or on a Dask cluster."""
