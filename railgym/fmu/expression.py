"""Arithmetic expressions of FMU variables: the outputs of a mapping file (``docs/fmi.md``).

An output of a mapping file may be an expression of the FMU's variables instead of one
variable, e.g. ``x1 - x2``, ``-a2``, ``0.001 * z_mm``, ``der(v1)``. Grammar::

    expr    := term (("+" | "-") term)*
    term    := unary (("*" | "/") unary)*
    unary   := "-" unary | primary
    primary := NUMBER | NAME | QUOTED | "der" "(" expr ")" | "(" expr ")"

``NAME`` is an FMI variable name ``[A-Za-z_][A-Za-z0-9_.\\[\\]]*`` (``body.a[1]``);
``QUOTED`` is any name in double quotes (``"der(v1)"``: the FMU's own variable of that
name); ``NUMBER`` a decimal number (``2``, ``0.5``, ``.5``, ``1e-3``). The text is tokenized
and parsed here into a tree of :class:`Num`, :class:`Var`, :class:`Neg`, :class:`Bin` and
:class:`Der` nodes, constant parts folded; nothing is ever evaluated as Python. Errors are
:class:`ExpressionError` with the 1-based column (the mapping adds the file and field).

``der(e)`` is the time derivative of ``e`` from its samples at the env's substeps ``t_k = k·h``
(:class:`Derivatives`): 0 at the reset (t = 0), the backward difference ``(y_1 − y_0)/h`` at
the first substep after it, then the second-order backward difference
``(3·y_k − 4·y_{k−1} + y_{k−2})/(2h)`` (exact for a quadratic in t; error ``h²/3·|y'''|``).

:func:`compile_expression` turns a tree into a function of the sampled variables
(``(n, n_variables)`` array, SI) that returns the expression's value at each of the ``n``
samples, vectorised over them.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

__all__ = [
    "Bin",
    "Der",
    "Derivatives",
    "Dim",
    "Expression",
    "ExpressionError",
    "Neg",
    "Num",
    "Var",
    "compile_expression",
    "dim_text",
    "dimension",
    "parse",
]

#: deepest nesting of parentheses and unary minus accepted
MAX_DEPTH = 100
_TOKEN = re.compile(
    r"(?P<space>\s+)"
    r"|(?P<num>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)"
    r"|(?P<name>[A-Za-z_][A-Za-z0-9_.\[\]]*)"
    r'|(?P<quoted>"[^"]*")'
    r"|(?P<op>[-+*/()])"
)
#: dimension: exponents of (m, s, kg)
Dim = tuple[int, int, int]


class ExpressionError(ValueError):
    """A bad expression; ``column`` (1-based) is where, 0 when it concerns the whole text."""

    def __init__(self, message: str, column: int = 0) -> None:
        super().__init__(message)
        self.column = column


class Num(NamedTuple):
    """A number (or a folded constant part)."""

    value: float
    column: int


class Var(NamedTuple):
    """An FMU variable."""

    name: str
    column: int


class Neg(NamedTuple):
    """Unary minus."""

    arg: Node
    column: int


class Bin(NamedTuple):
    """A binary operation ``+ - * /``."""

    op: str
    left: Node
    right: Node
    column: int  #: of the operator


class Der(NamedTuple):
    """The time derivative of ``arg`` (module docstring)."""

    arg: Node
    column: int


Node = Num | Var | Neg | Bin | Der


@dataclass(frozen=True)
class Expression:
    """A parsed expression: its text, tree, variables (in order of first use) and the
    number of ``der()`` terms (``Expression.of(name)``: the one variable ``name``)."""

    text: str
    root: Node
    names: tuple[str, ...]
    columns: tuple[int, ...]  #: of each name's first use, 1-based
    n_der: int

    @classmethod
    def of(cls, name: str) -> Expression:
        """The expression of the one variable ``name``."""
        return cls(name, Var(name, 1), (name,), (1,), 0)


class _Token(NamedTuple):
    kind: str  #: num, name, quoted, op, end
    text: str
    column: int


def _token(text: str, pos: int) -> tuple[_Token, int]:
    """The token at or after ``pos`` (spaces skipped) and the position after it."""
    m = _TOKEN.match(text, pos)
    while m is not None and m.lastgroup == "space":
        pos = m.end()
        m = _TOKEN.match(text, pos)
    if pos >= len(text):
        return _Token("end", "", len(text) + 1), pos
    if m is None:
        if text[pos] == '"':
            raise ExpressionError(f"unterminated quoted name at column {pos + 1}", pos + 1)
        raise ExpressionError(f"unexpected character {text[pos]!r} at column {pos + 1}", pos + 1)
    if m.lastgroup == "quoted" and len(m.group()) == 2:
        raise ExpressionError(f'empty quoted name "" at column {pos + 1}', pos + 1)
    return _Token(m.lastgroup or "", m.group(), pos + 1), m.end()


def _describe(tok: _Token) -> str:
    return "the end" if tok.kind == "end" else repr(tok.text)


class _Parser:
    """Recursive descent over the tokens (grammar: module docstring)."""

    def __init__(self, text: str) -> None:
        self.text = text
        self.pos = 0  #: in the text, after the look-ahead token
        self.next, self.pos = _token(text, 0)
        self.depth = 0
        self.names: dict[str, int] = {}  #: name → column of its first use
        self.n_der = 0

    def peek(self) -> _Token:
        return self.next

    def take(self) -> _Token:
        tok = self.next
        if tok.kind != "end":  # tokenized one at a time: the first error in reading order
            self.next, self.pos = _token(self.text, self.pos)
        return tok

    def expr(self) -> Node:
        node = self.term()
        while self.peek().text in ("+", "-") and self.peek().kind == "op":
            op = self.take()
            node = _fold(Bin(op.text, node, self.term(), op.column))
        return node

    def term(self) -> Node:
        node = self.unary()
        while self.peek().text in ("*", "/") and self.peek().kind == "op":
            op = self.take()
            node = _fold(Bin(op.text, node, self.unary(), op.column))
        return node

    def unary(self) -> Node:
        tok = self.peek()
        if tok.kind == "op" and tok.text == "-":
            self.take()
            return _fold(Neg(self.nested(self.unary), tok.column))
        return self.primary()

    def nested(self, parse: Callable[[], Node]) -> Node:
        self.depth += 1
        if self.depth > MAX_DEPTH:
            col = self.peek().column
            raise ExpressionError(f"nested more than {MAX_DEPTH} deep at column {col}", col)
        node = parse()
        self.depth -= 1
        return node

    def primary(self) -> Node:
        tok = self.take()
        if tok.kind == "num":
            return _number(float(tok.text), tok.column)
        if tok.kind == "quoted":
            return self.var(tok.text[1:-1], tok.column)
        if tok.kind == "name":
            if self.peek().text == "(":
                if tok.text != "der":
                    raise ExpressionError(
                        f"{tok.text!r} at column {tok.column} is not a function: der(...) is "
                        "the only one",
                        tok.column,
                    )
                self.n_der += 1
                return Der(self.group(self.take()), tok.column)
            return self.var(tok.text, tok.column)
        if tok.kind == "op" and tok.text == "(":
            return self.group(tok)
        raise ExpressionError(
            f"expected a number, a variable or '(' at column {tok.column}, got {_describe(tok)}",
            tok.column,
        )

    def group(self, open_: _Token) -> Node:
        """The expression after ``(`` up to its ``)``."""
        node = self.nested(self.expr)
        tok = self.take()
        if tok.kind == "op" and tok.text == ")":
            return node
        if tok.kind == "end":
            raise ExpressionError(
                f"unbalanced parenthesis: '(' at column {open_.column} is not closed",
                open_.column,
            )
        raise ExpressionError(
            f"expected an operator + - * / or ')' at column {tok.column}, got {_describe(tok)}",
            tok.column,
        )

    def var(self, name: str, column: int) -> Var:
        self.names.setdefault(name, column)
        return Var(name, column)


def _fold(node: Node) -> Node:
    """``node`` with constant operands computed (a division by a constant 0 is an error)."""
    if isinstance(node, Neg) and isinstance(node.arg, Num):
        return _number(-node.arg.value, node.column)
    if not isinstance(node, Bin):
        return node
    if node.op == "/" and isinstance(node.right, Num) and node.right.value == 0.0:
        raise ExpressionError(
            f"division by zero at column {node.column} (the divisor is the constant 0)",
            node.column,
        )
    if isinstance(node.left, Num) and isinstance(node.right, Num):
        a, b = node.left.value, node.right.value
        value = a + b if node.op == "+" else a - b if node.op == "-" else a * b
        if node.op == "/":
            value = a / b
        return _number(value, node.left.column)
    return node


def _number(value: float, column: int) -> Num:
    if not math.isfinite(value):
        raise ExpressionError(f"the number at column {column} is not finite ({value})", column)
    return Num(value, column)


def parse(text: str) -> Expression:
    """Parse ``text`` (grammar: module docstring); :class:`ExpressionError` when bad."""
    if not isinstance(text, str):
        raise ExpressionError(f"an expression must be a string, got {text!r}")
    if not text.strip():
        raise ExpressionError("the expression is empty")
    p = _Parser(text)
    root = p.expr()
    tok = p.peek()
    if tok.kind == "op" and tok.text == ")":
        raise ExpressionError(
            f"unbalanced parenthesis: ')' at column {tok.column} has no '('", tok.column
        )
    if tok.kind != "end":
        raise ExpressionError(
            f"expected an operator + - * / at column {tok.column}, got {_describe(tok)}",
            tok.column,
        )
    return Expression(text, root, tuple(p.names), tuple(p.names.values()), p.n_der)


def dimension(expr: Expression, dims: Mapping[str, Dim | None]) -> Dim | None:
    """The dimension of ``expr`` from its variables' ``dims`` (``None``: not known); a
    number is dimensionless in a sum (an offset) and makes a product's dimension unknown (it
    may carry a unit, as a lever arm does). Adding different known dimensions is an
    :class:`ExpressionError`."""

    def dim(node: Node) -> tuple[Dim | None, bool]:  # (dimension, is a number)
        if isinstance(node, Num):
            return None, True
        if isinstance(node, Var):
            return dims.get(node.name), False
        if isinstance(node, Neg):
            return dim(node.arg)
        if isinstance(node, Der):
            d, _ = dim(node.arg)
            return (None if d is None else (d[0], d[1] - 1, d[2])), False
        (a, num_a), (b, num_b) = dim(node.left), dim(node.right)
        if node.op in "+-":
            if a is not None and b is not None and a != b:
                what = f"{dim_text(a)} with {dim_text(b)}"
                raise ExpressionError(
                    f"{node.op!r} at column {node.column} combines {what}", node.column
                )
            return (b if num_a else a if num_b else a if a == b else None), False
        if a is None or b is None:
            return None, False
        sign = 1 if node.op == "*" else -1
        return (a[0] + sign * b[0], a[1] + sign * b[1], a[2] + sign * b[2]), False

    return dim(expr.root)[0]


def dim_text(d: Dim) -> str:
    """A dimension as a unit text (``m/s2``, ``kg.m/s2``)."""
    num = ".".join(
        f"{u}{e if e != 1 else ''}" for u, e in (("kg", d[2]), ("m", d[0]), ("s", d[1])) if e > 0
    )
    den = ".".join(
        f"{u}{-e if e != -1 else ''}" for u, e in (("kg", d[2]), ("m", d[0]), ("s", d[1])) if e < 0
    )
    return (num or "1") + (f"/{den}" if den else "")


class Derivatives:
    """The sample history of the ``der()`` terms of a set of outputs, stepped at ``h`` (s).

    :meth:`reset` starts a run (the next samples are those of t = 0); with ``replace``
    false the samples given are new ones (the next times), with ``replace`` true the first
    replaces the latest stored one (the outputs at the same time read again)."""

    def __init__(self, n: int, h: float) -> None:
        self.h = float(h)
        self.replace = False
        self._hist = [np.empty(0) for _ in range(n)]

    def reset(self) -> None:
        """Forget every sample: the next ones start at t = 0."""
        self._hist = [np.empty(0) for _ in self._hist]
        self.replace = False

    def __call__(self, slot: int, y: np.ndarray) -> np.ndarray:
        """The derivative (per s) of term ``slot`` at the samples ``y`` (n,)."""
        prev = self._hist[slot]
        if self.replace and prev.size:
            prev = prev[:-1]
        ext = np.concatenate([prev, y])
        p = np.arange(prev.size, ext.size)
        out = np.zeros(p.size)
        two = p >= 2
        k = p[two]
        out[two] = (3.0 * ext[k] - 4.0 * ext[k - 1] + ext[k - 2]) / (2.0 * self.h)
        if prev.size <= 1 < ext.size:
            out[1 - prev.size] = (ext[1] - ext[0]) / self.h
        self._hist[slot] = ext[-3:].copy()
        return out


Evaluator = Callable[[np.ndarray, Derivatives], np.ndarray]


def compile_expression(
    expr: Expression, columns: Mapping[str, int], factors: Mapping[str, float], first_der: int = 0
) -> Evaluator:
    """A function ``(raw, ders) → values``: ``raw`` (n, ·) the sampled FMU variables (the
    variable ``name`` in column ``columns[name]``, times ``factors[name]`` to SI), ``ders``
    the :class:`Derivatives` whose slots ``first_der …`` hold this expression's ``der()``
    terms; the values (n,)."""
    slots = iter(range(first_der, first_der + expr.n_der))

    def build(node: Node) -> Evaluator:
        if isinstance(node, Num):
            value = node.value
            return lambda raw, d: np.full(raw.shape[0], value)
        if isinstance(node, Var):
            j, f = columns[node.name], factors[node.name]
            return lambda raw, d: raw[:, j] * f
        if isinstance(node, Neg):
            arg = build(node.arg)
            return lambda raw, d: -arg(raw, d)
        if isinstance(node, Der):
            slot, inner = next(slots), build(node.arg)
            return lambda raw, d: d(slot, inner(raw, d))
        a, b = build(node.left), build(node.right)
        if node.op == "+":
            return lambda raw, d: a(raw, d) + b(raw, d)
        if node.op == "-":
            return lambda raw, d: a(raw, d) - b(raw, d)
        if node.op == "*":
            return lambda raw, d: a(raw, d) * b(raw, d)
        return lambda raw, d: a(raw, d) / b(raw, d)

    return build(expr.root)
