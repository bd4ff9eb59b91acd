"""Guides shaped by hand (Šik 2012 §2.2.5): the brushing session and its stroke log.

- :mod:`~follicle.editing.editor`: :class:`~follicle.editing.editor.GuideEditor`, the
  brushes of :mod:`follicle.groom.brushes` applied through a camera's view, with undo,
  symmetry and the skin's depth for picking; :func:`~follicle.editing.editor.replay_file`
  (``follicle groom``);
- :mod:`~follicle.editing.strokes`: the stroke log, a JSON file of every stroke and the
  view it was made in, replayed to the same guides.

It sits above ``groom`` and ``render``: it picks through a camera and the CPU engine's
skin depth, which the grooming stage itself never needs.
"""
