"""Sparse data-driven terms in the compiled loops: the terms as numbers in a table row.

:class:`~pdmkit.models.mismatch._sparse.SparseTerms` builds its term from a list chosen
by the data, so its ``derivs`` hook loops over Python objects and cannot be translated
like the named effects (:mod:`pdmkit.models.ode._compiled_effects`). Instead it gives
the compiled loops :data:`SOURCE`, one scalar function for every set of terms, and
:func:`term_row` writes its terms into the effect's option row: the number of terms,
then per term its normalisation and factors, each factor as ``(namespace, index, op,
width)``. The function computes what ``Term.evaluate`` computes, in the same order.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

__all__ = ["SOURCE", "term_row"]

#: op codes of a factor: powers are their exponent
_OPS = {"abs": 10, "sign": 11, "sqrt": 12}

#: ``derivs`` of a set of sparse terms, scalar (the loops' uniform signature)
SOURCE = """
def _derivs(t, x, u, p, dx, tg, pr, th0, zo, op):
    acc = dx[tg]
    k = 1
    for j in range(int(op[0])):
        norm = op[k]
        nf = int(op[k + 1])
        k += 2
        term = 1.0
        for f in range(nf):
            idx = int(op[k + 1])
            code = int(op[k + 2])
            a = x[idx] if op[k] == 0.0 else u[idx]
            if code == 1:
                v = a
            elif code == 2:
                v = a * a
            elif code == 10:
                v = abs(a)
            elif code == 11:
                v = np.tanh(a / op[k + 3])
            elif code == 12:
                v = np.sqrt(abs(a))
            else:
                v = a ** float(code)
            term = v if f == 0 else term * v
            k += 4
        acc = acc + (p[th0 + j] * norm) * term
    dx[tg] = acc
"""


def term_row(
    terms: Sequence, norms: Sequence[float], eps: Mapping[str, float], layout: Mapping
) -> list[float] | None:
    """The option row of a set of terms, or None where a variable is not in ``layout``.

    Examples
    --------
    >>> from pdmkit.models.mismatch._sparse import Term
    >>> term_row([Term((("v", "sign"),))], [2.0], {"v": 0.1}, {"x": ["x", "v"], "u": []})
    [1.0, 2.0, 1.0, 0.0, 1.0, 11.0, 0.1]
    """
    states, inputs = list(layout["x"]), list(layout["u"])
    row = [float(len(terms))]
    for term, norm in zip(terms, norms, strict=True):
        row += [float(norm), float(len(term.factors))]
        for var, op in term.factors:
            if var in states:
                where = [0.0, float(states.index(var))]
            elif var in inputs:
                where = [1.0, float(inputs.index(var))]
            else:
                return None
            code = op if isinstance(op, int) else _OPS.get(op)
            if code is None or (isinstance(op, int) and op < 1):
                return None
            width = float(eps.get(var, math.nan)) if op == "sign" else 0.0
            row += [*where, float(code), width]
    return row
