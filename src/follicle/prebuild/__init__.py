"""The programs that compile follicle's kernels ahead of their use: the workload that runs
every kernel through follicle's own commands (:mod:`.workload`), its runner over several
processes (:mod:`.runner`), and the build of the kernels a wheel ships (:mod:`.build`).

It stands above the command line, whose commands it runs; ``follicle warm`` starts it as
a process of its own (``python -m follicle.prebuild warm``), and so does a wheel's build
(``python -m follicle.prebuild build``).
"""
