"""Command-line parameters that ROS dropped without a word (a double given for an integer).

May import rclpy (a node's parameters) and the standard library.
"""

from __future__ import annotations

from rclpy.node import Node


def _cli_parameters(argv: list[str]) -> list[tuple[str, str]]:
    """``(name, value text)`` of every ``-p name:=value`` in the ROS arguments of ``argv``."""
    out, ros = [], False
    it = iter(argv)
    for tok in it:
        if tok == "--ros-args":
            ros = True
        elif tok == "--":
            ros = False
        elif ros and tok in ("-p", "--param"):
            item = next(it, "")
            if ":=" in item:
                name, _, text = item.partition(":=")
                out.append((name.split(":")[-1], text))  # node-name prefix "node:name" allowed
    return out


def ignored_cli_parameters(node: Node, argv: list[str]) -> list[str]:
    """Command-line values ROS dropped without a word.

    With ``--params-file`` holding ``n_links: 8``, rcl silently keeps the file's integer when
    ``-p n_links:=2.0`` gives a double, so the run would quietly use 8 links. Returns one message
    per such parameter (an integer for a double is fine: the node takes it as that double).
    """
    problems = []
    for name, text in _cli_parameters(argv):
        if not node.has_parameter(name):
            continue
        actual = node.get_parameter(name).value
        if isinstance(actual, bool) or not isinstance(actual, int):
            continue
        try:
            given = float(text)
        except ValueError:
            continue
        if given != actual or not text.lstrip("+-").isdigit():
            problems.append(f"parameter '{name}' = {text} is not an integer; '{name}' is an integer "
                            f"parameter (write {name}:={int(given) if given.is_integer() else '<integer>'})")
    return problems
