"""Settings written as text (the RL Zoo's ``policy_kwargs: "dict(net_arch=[64, 64], activation_fn=nn.ELU)"``), parsed
without running them.

rl_zoo3 ``eval``s such strings; we parse them with :mod:`ast` and accept only literals (numbers, strings, booleans,
``None``, lists, tuples, dicts), ``dict(key=value, ...)`` and the names of :data:`ACTIVATIONS` and
:data:`OPTIMIZERS`. Anything else (a call, an attribute of another module, a name, an import) is a ``ValueError``
that names the setting and what was found: a settings file or a command-line option can never run code.
"""

from __future__ import annotations

import ast
from typing import Any

import torch as th

#: activation functions a setting may name, as ``nn.X``, ``th.nn.X`` or ``torch.nn.X``
ACTIVATIONS = {name: getattr(th.nn, name) for name in (
    "ReLU", "ELU", "Tanh", "LeakyReLU", "GELU", "SiLU", "Sigmoid", "Softplus", "Mish", "SELU", "Identity")}
#: optimisers a setting may name, as ``th.optim.X`` or ``torch.optim.X``
OPTIMIZERS = {name: getattr(th.optim, name) for name in ("Adam", "AdamW", "SGD", "RMSprop")}
_PREFIXES = {("nn",): ACTIVATIONS, ("th", "nn"): ACTIVATIONS, ("torch", "nn"): ACTIVATIONS,
             ("th", "optim"): OPTIMIZERS, ("torch", "optim"): OPTIMIZERS}


def _dotted(node: ast.AST) -> tuple[str, ...] | None:
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if isinstance(node, ast.Name):
        return (node.id, *reversed(parts))
    return None


def _value(node: ast.AST, name: str, text: str) -> Any:
    def refuse(what: str):
        raise ValueError(f"{name}: expected literals, dict(...) and the names {sorted(f'nn.{a}' for a in ACTIVATIONS)} "
                         f"or {sorted(f'th.optim.{o}' for o in OPTIMIZERS)}, found {what} in {text!r}")

    if isinstance(node, ast.Constant):
        return node.value
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)) and isinstance(node.operand, ast.Constant) \
            and isinstance(node.operand.value, (int, float)) and not isinstance(node.operand.value, bool):
        return -node.operand.value if isinstance(node.op, ast.USub) else node.operand.value
    if isinstance(node, (ast.List, ast.Tuple)):
        items = [_value(e, name, text) for e in node.elts]
        return items if isinstance(node, ast.List) else tuple(items)
    if isinstance(node, ast.Dict):
        if any(k is None for k in node.keys):
            refuse("'**' unpacking")
        return {_value(k, name, text): _value(v, name, text) for k, v in zip(node.keys, node.values)}
    if isinstance(node, ast.Call):
        if not (isinstance(node.func, ast.Name) and node.func.id == "dict") or node.args \
                or any(k.arg is None for k in node.keywords):
            refuse(f"the call {ast.unparse(node)!r}")
        return {k.arg: _value(k.value, name, text) for k in node.keywords}
    dotted = _dotted(node)
    if dotted is not None and len(dotted) >= 2 and dotted[:-1] in _PREFIXES and dotted[-1] in _PREFIXES[dotted[:-1]]:
        return _PREFIXES[dotted[:-1]][dotted[-1]]
    refuse(repr(ast.unparse(node)))


def parse_setting(text: str, name: str = "policy_kwargs") -> Any:
    """The value a settings string stands for, parsed without running it (see the module's docstring)."""
    if not isinstance(text, str):
        raise ValueError(f"{name}: expected a string to parse, found {type(text).__name__}")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as e:
        raise ValueError(f"{name}: expected a Python literal or dict(...), found {text!r} ({e.msg})") from None
    return _value(tree.body, name, text)


def parse_policy_kwargs(value: str | dict | None, name: str = "policy_kwargs") -> dict | None:
    """``policy_kwargs`` given as a dict (returned as is) or as the RL Zoo's string, parsed into a dict."""
    if value is None or isinstance(value, dict):
        return value
    parsed = parse_setting(value, name)
    if not isinstance(parsed, dict):
        raise ValueError(f"{name}: expected a dict, found {parsed!r}")
    return parsed
