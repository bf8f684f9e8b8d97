"""The CREATIO model as formulas: pure NumPy and scalar Python, no compiler (docs/model.md).

* :mod:`~creatio.model.laws`: time laws of the phases and the inclination (s.2);
* :mod:`~creatio.model.surface`: the corrugated surface, its derivatives, metric, normal (s.1);
* :mod:`~creatio.model.cavity`: pattern motion, cavities, helical pitch (s.3);
* :mod:`~creatio.model.offset`: exact jets of the sphere centre X = c + b n (s.4);
* :mod:`~creatio.model.sphere`: the sphere's contact closed forms and stability estimate (s.4-6);
* :mod:`~creatio.model.numerics`: step counts, observed orders, Runge-Kutta stability bounds;
* :mod:`~creatio.model.actuation`: what a prescribed cycle asks of the actuators (s.12.1);
* :mod:`~creatio.model.oscillation`: small oscillations in a still cavity (s.12.3).

Each formula lives here once; the dynamics layer compiles the scalar ones into its loops.
"""
