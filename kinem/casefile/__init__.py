"""The case-file loader, split by concern (kinem.case is its front door):
``checks`` (the problem list and the scalar rules every value obeys),
``keys`` (the key kinds of constraint types, as classes), ``sections``
(units, parameters, time, solver, engines, bodies, points), ``drawn``
(frames and local coordinates of bodies named by points drawn in the global
frame), ``curves`` (time functions
and outlines), ``constraints`` (the [[constraints]] tables) and ``docs``
(docs/case-format.md's generated tables).

Kept free of imports so that kinem.constraints can import ``keys``."""
