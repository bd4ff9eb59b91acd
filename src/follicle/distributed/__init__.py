"""follicle on a Dask cluster: every job split into tasks, each output the same bytes as
one process makes.

- :mod:`~follicle.distributed.cluster`: connecting, sending tasks, taking their results
  in order, the parts that workers hand back;
- :mod:`~follicle.distributed.grow`: a groom grown in ranges of hair ids
  (``follicle grow --scheduler``);
- :mod:`~follicle.distributed.simulate`: scenes simulated one per task
  (``follicle batch --simulate``);
- :mod:`~follicle.distributed.render`: a cache's frames rendered in runs
  (``follicle render CACHE --scheduler``);
- :mod:`~follicle.distributed.export`: many curves files converted
  (``follicle export IN... -o FOLDER``);
- :mod:`~follicle.distributed.batch`: variants of a scene, grown, simulated and rendered
  into a dataset with a manifest (``follicle batch``).

The package imports nothing itself (Dask loads when a job starts); import the module
whose function you call, e.g. ``from follicle.distributed.grow import grow``.
"""
