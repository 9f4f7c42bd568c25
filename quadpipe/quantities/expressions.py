"""Safe quantity expressions: parsing, type and dimension checking, compiling to numpy.

Controller values are numbers with units (`38/30 s`, `0.5 bw`), vectors (`[0, 0, -1]`) or
expressions over them (`0.3 bw * smoothstep(1 s, 2 s, t)`). Text is parsed with Python's
`ast` after two rewrites: a unit written after a number binds to it (`38/30 s` is
`(38/30)*s`, `x / 2 s` is `x / (2*s)`), and `^` means a power. Only a whitelist of syntax
is accepted (arithmetic, comparisons, `and`/`or`/`not`, `a if c else b`, vector literals,
calls of the functions in `FUNCTIONS`, `role.start`-style points and `.x/.y/.z` components);
anything else is refused before evaluation, so no Python object is ever reached.

Checking gives every node a `Type` (scalar, vector or condition, with a `Dim`) and rejects
mixed dimensions. Compiling for a `Scale` (one value per animal) gives a `Compiled`
callable `f(env) -> array` evaluated for all animals at once: scalars are arrays of shape
(n,), vectors (n, 3), conditions boolean (n,). Sub-expressions that need nothing from the
simulation are folded to constants at compile time.

How the simulation state reaches an expression (`env`), and what degenerate values give, is
said once, in `quadpipe.quantities.evaluation`.

This module gathers the language's public names; the work is done in
`nodes.py` (types, `Expr`, env keys), `functions.py` (the function table), `parsing.py`
(text to a whitelisted AST), `checking.py` (names, types, dimensions) and `evaluation.py`
(compiling to numpy).
"""

from quadpipe.quantities.checking import (
    Namespace,
    check,
    check_expected,
    compile_quantity,
    make_vector,
    resolve_point_name,
)
from quadpipe.quantities.evaluation import Compiled, Env, compile_expr, evaluate_constant, table_rows
from quadpipe.quantities.functions import FUNCTIONS, LOCAL_HELP, LOCAL_NAMES, SPECIAL_ARGUMENT_FUNCTIONS, Function
from quadpipe.quantities.nodes import (
    BOOL,
    CALL_NEEDS,
    COMPONENTS,
    CONDITION,
    CONSTANTS,
    HEADING_FRAME_KEY,
    LEG_LANDMARKS,
    LEG_REST_LENGTH,
    NUMBER,
    POINT_ANCHORS,
    POINT_TYPE,
    REST_PREFIX,
    SCALAR,
    TIME_VARIABLE,
    VECTOR,
    ZERO_NORM,
    Expect,
    Expr,
    ExprError,
    Type,
    point_key,
    rest_distance_key,
)
from quadpipe.quantities.parsing import parse, referenced_names, rewrite

__all__ = [
    "BOOL",
    "CALL_NEEDS",
    "COMPONENTS",
    "CONDITION",
    "CONSTANTS",
    "Compiled",
    "Env",
    "Expect",
    "Expr",
    "ExprError",
    "FUNCTIONS",
    "Function",
    "HEADING_FRAME_KEY",
    "LEG_LANDMARKS",
    "LEG_REST_LENGTH",
    "LOCAL_HELP",
    "LOCAL_NAMES",
    "NUMBER",
    "Namespace",
    "POINT_ANCHORS",
    "POINT_TYPE",
    "REST_PREFIX",
    "SCALAR",
    "SPECIAL_ARGUMENT_FUNCTIONS",
    "TIME_VARIABLE",
    "Type",
    "VECTOR",
    "ZERO_NORM",
    "check",
    "check_expected",
    "compile_expr",
    "compile_quantity",
    "evaluate_constant",
    "make_vector",
    "parse",
    "point_key",
    "referenced_names",
    "resolve_point_name",
    "rest_distance_key",
    "rewrite",
    "table_rows",
]
