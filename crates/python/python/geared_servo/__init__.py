"""geared_servo: the DC-motor servo with a two-stage gear reducer and backlash, in Python.

The model is the one the firmware runs and the ``geared-servo`` command line calibrates
(the Rust host library, compiled into ``geared_servo._native``): parameters, time-domain
simulation, stepped-sine frequency response, design queries and diagnosis, numpy arrays in
and out. Results are those of the command line (its ``--json`` objects, as dicts); errors
are exceptions with its one-line messages: ``InputError`` (a ``ValueError``) for bad input,
``ModelError`` (a ``RuntimeError``) for the rest.

    import geared_servo as gs
    p = gs.Params.reference()                 # or gs.Params.from_toml("calibrated.toml")
    p.backlash.total_deg = 0.08               # validated at once
    out = gs.simulate(p, volts, dt=0.0005)    # dict of numpy arrays
    gs.resonances(p, vpk=10.0)["f_ar_hz"]
    d = gs.diagnose(p, "meas.csv")            # or a DataFrame, or a dict of arrays;
                                              # progress=print shows each phase as it ends
    d.report["final"]["fit_percent"], d.params.to_toml()
"""

from . import _native
from ._native import (
    OUTPUT_COLUMNS,
    SIMULATE_COLUMNS,
    Diagnosis,
    InputError,
    ModelError,
    Params,
    bode,
    diagnose,
    max_backlash,
    min_voltage,
    resonances,
    simulate,
)

__all__ = [
    "Params",
    "Diagnosis",
    "InputError",
    "ModelError",
    "simulate",
    "bode",
    "resonances",
    "max_backlash",
    "min_voltage",
    "diagnose",
    "SIMULATE_COLUMNS",
    "OUTPUT_COLUMNS",
]


class _Table:
    """A table of a parameter set (``p.motor``): its keys are attributes, read and set
    through the set, which validates every change."""

    __slots__ = ("_params",)
    _table = ""
    _keys = ()

    def __init__(self, params):
        object.__setattr__(self, "_params", params)

    def __setattr__(self, name, value):
        # Only the keys (properties) can be set; anything else is a typo.
        if name not in self._keys:
            raise AttributeError(
                f"table [{self._table}] has no key `{name}` (keys: {', '.join(self._here())})"
            )
        object.__setattr__(self, name, value)

    def _here(self):
        """The keys of this table that the set has (its stiffness form decides)."""
        return [k for k in self._keys if f"{self._table}.{k}" in self._params]

    def __dir__(self):
        return self._here()

    def __repr__(self):
        p = self._params
        lines = [f"[{self._table}] of {p.name}"]
        for k in self._here():
            key = f"{self._table}.{k}"
            lines.append(f"  {k} = {p[key]!r} {p.unit(key)}")
        return "\n".join(lines)


def _key_property(key, unit, description):
    def get(self):
        try:
            return self._params[key]
        except KeyError as e:
            raise AttributeError(e.args[0]) from None

    def put(self, value):
        self._params[key] = value

    unit_text = "dimensionless" if unit == "-" else unit
    doc = f"`{key}`, {unit_text}" + (f": {description}" if description else "")
    return property(get, put, doc=doc)


def _tables():
    """One class per table of the parameter file, a documented property per key: built from
    the native schema (the file's own list of keys and units), so nothing here lists them."""
    keys = {}
    for key, unit, description in _native.schema():
        if "." in key:
            table, name = key.split(".", 1)
            keys.setdefault(table, []).append((name, key, unit, description))
    classes = {}
    for table, entries in keys.items():
        doc = f"Table [{table}] of the parameter file. Keys (set one to validate the set):\n" + "\n".join(
            f"    {name}: {'dimensionless' if unit == '-' else unit}"
            + (f" -- {description}" if description else "")
            for name, _, unit, description in entries
        )
        attrs = {name: _key_property(key, unit, description) for name, key, unit, description in entries}
        attrs.update(
            __doc__=doc,
            __slots__=(),
            _table=table,
            _keys=tuple(name for name, *_ in entries),
        )
        classes[table] = type(f"{table}", (_Table,), attrs)
    return classes


_native.register_tables(_tables())
