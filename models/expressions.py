"""Load expressions for ``dualmech simulate``: a small, bounded evaluator over a whitelisted AST.

An expression such as ``"100*(1 - psidot/50)"`` or ``"10000*(s4 - 0.5) + 1000*s4dot"``
is parsed once; :func:`load_expression` returns a function of
``(t, psi, psidot, s4, s4dot)`` that walks the tree in plain floats.  Nothing in
it can run long or leave the real numbers:

* only numbers, the variables :data:`EXPRESSION_VARIABLES`, the constants ``pi``
  and ``e``, arithmetic, comparisons, ``and/or/not``, ``a if c else b`` and the
  functions of :data:`EXPRESSION_FUNCTIONS` are accepted;
* the text is at most :data:`MAX_EXPRESSION_CHARS` characters and the tree at most
  :data:`MAX_EXPRESSION_NODES` nodes and :data:`MAX_EXPRESSION_DEPTH` levels, so one
  evaluation is a bounded number of float operations (microseconds);
* every number is a float (no unbounded integer arithmetic): ``9**9**9`` is refused
  when parsed, because its constant exponent ``9**9`` exceeds :data:`MAX_EXPONENT`;
* a result outside the reals (``sqrt(-1)``, ``(-8)**(1/3)``, ``log(0)``, ``1/0``) or a
  non-finite one (``exp(1000)``) is a one-line ``ValueError`` naming the expression and
  the state, never a ``nan`` handed to the integrator;
* a value beyond the case-number bound ``SCALE`` (1e15, ``models/case.py``) is refused;
* each evaluation also stops at a wall-time limit (:data:`EXPRESSION_TIME_LIMIT`), the garbage collector
  off while it runs (a collection of the whole heap is not the expression's time).
"""

from __future__ import annotations

import ast
import gc
import math
import operator
import time
from typing import Any, Callable

from dualmech.models.inputs import SCALE

#: A load as a function of time and state: ``f(t, psi, psi_dot, s4, s4_dot) -> float``.
LoadFunction = Callable[[float, float, float, float, float], float]

#: Names a load expression may use (``dualmech simulate --torque``).
EXPRESSION_VARIABLES = ("t", "psi", "psidot", "s4", "s4dot")
#: Longest expression text, characters.
MAX_EXPRESSION_CHARS = 1000
#: Most AST nodes and deepest nesting of one expression (a load law is a few dozen nodes).
MAX_EXPRESSION_NODES = 500
MAX_EXPRESSION_DEPTH = 40
#: Largest exponent magnitude of ``**``: load laws are low-degree polynomials, and with every
#: case number below 1e15 (models/case.py, SCALE) a power of at most 16 stays below 1e240.
MAX_EXPONENT = 16.0
#: Wall time one evaluation may take, seconds (a bounded tree takes microseconds).
EXPRESSION_TIME_LIMIT = 0.05


def _quote(text: str) -> str:
    """The expression as quoted in messages, cut to 80 characters."""
    return repr(text) if len(text) <= 80 else repr(text[:77] + "...")


def _sign(x: float) -> float:
    return float((x > 0) - (x < 0))


def _mod(a: float, b: float) -> float:
    return a % b  # the sign of the divisor, as numpy.mod


#: Functions an expression may call: name -> (number of arguments, scalar implementation).
EXPRESSION_FUNCTIONS: dict[str, tuple[int, Callable[..., float]]] = {
    "sin": (1, math.sin), "cos": (1, math.cos), "tan": (1, math.tan),
    "arcsin": (1, math.asin), "arccos": (1, math.acos), "arctan": (1, math.atan), "arctan2": (2, math.atan2),
    "sinh": (1, math.sinh), "cosh": (1, math.cosh), "tanh": (1, math.tanh),
    "exp": (1, math.exp), "log": (1, math.log), "log10": (1, math.log10), "sqrt": (1, math.sqrt),
    "abs": (1, abs), "sign": (1, _sign), "floor": (1, lambda x: float(math.floor(x))),
    "minimum": (2, min), "maximum": (2, max), "mod": (2, _mod),
    "where": (3, lambda c, a, b: a if c else b), "clip": (3, lambda x, lo, hi: min(max(x, lo), hi)),
}
_CONSTANTS = {"pi": math.pi, "e": math.e}
_BINARY: dict[type, Callable[[float, float], float]] = {
    ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
    ast.Mod: _mod, ast.FloorDiv: operator.floordiv,
}
_COMPARE: dict[type, Callable[[float, float], bool]] = {
    ast.Lt: operator.lt, ast.LtE: operator.le, ast.Gt: operator.gt, ast.GtE: operator.ge,
    ast.Eq: operator.eq, ast.NotEq: operator.ne,
}
_ALLOWED_NODES = (
    ast.Expression, ast.BinOp, ast.UnaryOp, ast.Constant, ast.Name, ast.Load, ast.Call, ast.Compare,
    ast.IfExp, ast.BoolOp, ast.And, ast.Or, ast.Not, ast.USub, ast.UAdd, ast.Pow, *_BINARY, *_COMPARE,
)


class _Evaluator:
    """Walks one parsed expression in floats; every failure is a one-line ``ValueError``."""

    def __init__(self, text: str, tree: ast.Expression) -> None:
        self.text = text
        self.tree = tree
        self.names: dict[str, float] = dict(_CONSTANTS)
        self.deadline = math.inf

    def fail(self, why: str) -> ValueError:
        state = ", ".join(f"{k}={self.names[k]:.6g}" for k in EXPRESSION_VARIABLES if k in self.names)
        return ValueError(f"load expression {_quote(self.text)}: {why}" + (f" at {state}" if state else ""))

    def __call__(self, names: dict[str, float]) -> float:
        self.names = {**_CONSTANTS, **names}
        collecting = gc.isenabled()
        gc.disable()  # a collection of the process's heap (~60 ms, kernels loaded) is not this evaluation's
        try:
            self.deadline = time.perf_counter() + EXPRESSION_TIME_LIMIT
            return self.result(self.node(self.tree.body))
        finally:
            if collecting:
                gc.enable()

    def number(self, value: Any) -> float:
        value = float(value)
        if not math.isfinite(value):
            raise self.fail(f"gives {value!r}; a load must be a finite number")
        return value

    def result(self, value: Any) -> float:
        value = self.number(value)
        if abs(value) > SCALE:
            raise self.fail(f"gives {value:g}, beyond the largest load magnitude {SCALE:g} "
                            "(docs/conventions.md, Input ranges)")
        return value

    def power(self, base: float, exponent: float) -> float:
        if abs(exponent) > MAX_EXPONENT:
            raise self.fail(f"exponent {exponent:g} exceeds {MAX_EXPONENT:g} in magnitude")
        return math.pow(base, exponent)  # ValueError for a complex result, OverflowError past the floats

    def node(self, node: ast.AST) -> Any:
        if time.perf_counter() > self.deadline:
            raise self.fail(f"evaluation took longer than {EXPRESSION_TIME_LIMIT} s")
        try:
            return self.number(self._node(node)) if not isinstance(node, (ast.Compare, ast.BoolOp)) \
                else self._node(node)
        except (ArithmeticError, TypeError) as err:  # ZeroDivision, Overflow; math domain errors below
            raise self.fail(f"{type(err).__name__} ({err})") from None
        except ValueError as err:
            if str(err).startswith("load expression"):
                raise
            raise self.fail(f"{err} (the result is not a real number)") from None

    def _node(self, node: ast.AST) -> Any:
        if isinstance(node, ast.Constant):
            return node.value
        if isinstance(node, ast.Name):
            return self.names[node.id]
        if isinstance(node, ast.UnaryOp):
            value = self.node(node.operand)
            if isinstance(node.op, ast.Not):
                return not value
            return -value if isinstance(node.op, ast.USub) else value
        if isinstance(node, ast.BinOp):
            a, b = self.node(node.left), self.node(node.right)
            return self.power(a, b) if isinstance(node.op, ast.Pow) else _BINARY[type(node.op)](a, b)
        if isinstance(node, ast.Compare):
            values = [self.node(node.left), *(self.node(c) for c in node.comparators)]
            return all(_COMPARE[type(op)](x, y) for op, x, y in zip(node.ops, values, values[1:]))
        if isinstance(node, ast.BoolOp):
            values = [bool(self.node(v)) for v in node.values]
            return all(values) if isinstance(node.op, ast.And) else any(values)
        if isinstance(node, ast.IfExp):
            return self.node(node.body) if self.node(node.test) else self.node(node.orelse)
        _, func = EXPRESSION_FUNCTIONS[node.func.id]  # ast.Call, checked by _check_tree
        return func(*(self.node(a) for a in node.args))


def _depth(tree: ast.AST) -> int:
    deepest, stack = 0, [(tree, 1)]
    while stack:
        node, level = stack.pop()
        deepest = max(deepest, level)
        stack.extend((child, level + 1) for child in ast.iter_child_nodes(node))
    return deepest


def _check_tree(text: str, tree: ast.Expression) -> None:
    """Whitelist of nodes, names, calls and constants; bounded size and depth."""
    nodes = list(ast.walk(tree))
    if len(nodes) > MAX_EXPRESSION_NODES or _depth(tree) > MAX_EXPRESSION_DEPTH:
        raise ValueError(f"load expression {_quote(text)}: more than {MAX_EXPRESSION_NODES} terms or "
                         f"{MAX_EXPRESSION_DEPTH} levels of nesting")
    allowed = set(EXPRESSION_VARIABLES) | set(_CONSTANTS)
    called = {id(n.func) for n in nodes if isinstance(n, ast.Call)}
    for node in nodes:
        if not isinstance(node, _ALLOWED_NODES):
            raise ValueError(f"load expression: {type(node).__name__} not allowed in {_quote(text)}")
        if isinstance(node, ast.Name) and node.id not in allowed | set(EXPRESSION_FUNCTIONS):
            raise ValueError(f"load expression: unknown name {node.id!r} in {_quote(text)} "
                             f"(variables: {', '.join(EXPRESSION_VARIABLES)})")
        if isinstance(node, ast.Call):
            if (not isinstance(node.func, ast.Name) or node.func.id not in EXPRESSION_FUNCTIONS
                    or node.keywords):
                raise ValueError(f"load expression: only calls of {', '.join(EXPRESSION_FUNCTIONS)} "
                                 "are allowed")
            arity = EXPRESSION_FUNCTIONS[node.func.id][0]
            if len(node.args) != arity:
                raise ValueError(f"load expression: {node.func.id} takes {arity} argument(s), "
                                 f"got {len(node.args)} in {_quote(text)}")
        elif isinstance(node, ast.Name) and node.id in EXPRESSION_FUNCTIONS and id(node) not in called:
            raise ValueError(f"load expression: {node.id!r} is a function; call it, e.g. {node.id}(psi)")
        if isinstance(node, ast.Constant) and (isinstance(node.value, bool)
                                               or not isinstance(node.value, (int, float))):
            raise ValueError(f"load expression: constant {repr(node.value)[:40]} is not a number")


def _fold_constants(text: str, evaluator: _Evaluator, tree: ast.expr) -> None:
    """Evaluate every largest variable-free sub-expression once, now: ``9**9**9`` fails at parse time."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, int) and abs(node.value) > 2**1023:
            raise ValueError(f"load expression {_quote(text)}: integer constant too large for a float")
    stack = [tree]
    while stack:
        node = stack.pop()
        if any(isinstance(n, ast.Name) and n.id in EXPRESSION_VARIABLES for n in ast.walk(node)):
            stack.extend(c for c in ast.iter_child_nodes(node) if isinstance(c, ast.expr))
        elif not isinstance(node, ast.Name):  # a function name needs no evaluation
            evaluator.names = dict(_CONSTANTS)
            evaluator.deadline = time.perf_counter() + EXPRESSION_TIME_LIMIT
            evaluator.node(node)


def load_expression(text: str) -> LoadFunction:
    """A load function from an expression in ``t, psi, psidot, s4, s4dot`` (the case's units).

    Allowed: numbers, arithmetic (``+ - * / % // **``, exponents at most
    :data:`MAX_EXPONENT` in magnitude), comparisons, ``and or not``,
    ``a if cond else b``, the constants ``pi, e`` and the functions ``sin cos tan
    arcsin arccos arctan arctan2 sinh cosh tanh exp log log10 sqrt abs sign
    minimum maximum where clip floor mod``.  Examples: ``"500"``,
    ``"100*(1 - psidot/50)"``, ``"10000*(s4 - 0.5) + 1000*s4dot"``.

    Raises
    ------
    ValueError
        One line, when the text is not such an expression, is too long, or one of
        its constant parts is not a finite real number; the returned function
        raises it when a value at a given state is not a finite real number.
    """
    text = str(text).strip()
    if len(text) > MAX_EXPRESSION_CHARS:
        raise ValueError(f"load expression: {len(text)} characters; at most {MAX_EXPRESSION_CHARS}")
    try:
        tree = ast.parse(text, mode="eval")
    except (SyntaxError, ValueError, RecursionError, MemoryError):  # ValueError: a NUL byte
        raise ValueError(f"load expression: cannot parse {_quote(text)}") from None
    _check_tree(text, tree)
    evaluator = _Evaluator(text, tree)
    _fold_constants(text, evaluator, tree.body)
    if not any(isinstance(n, ast.Name) and n.id in EXPRESSION_VARIABLES for n in ast.walk(tree)):
        const = evaluator({})  # a constant load: its range is checked now, not at the first step
        return lambda t, psi, psidot, s4, s4dot: const

    def load(t: float, psi: float, psidot: float, s4: float, s4dot: float) -> float:
        return evaluator({"t": t, "psi": psi, "psidot": psidot, "s4": s4, "s4dot": s4dot})

    return load
