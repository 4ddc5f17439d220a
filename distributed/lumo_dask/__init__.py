"""lumo-dask: render a lumo scene on a Dask cluster, one task per chunk of samples."""

__version__ = "0.1.0"
