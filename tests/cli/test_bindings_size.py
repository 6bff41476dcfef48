"""The pybind11 bindings (native/bindings) stay in short functions: none over MAX_LINES
lines, counted from its definition line to its closing brace. Lambdas defined at
namespace scope count as functions; lambdas inside a function count towards it.

The parser is deliberately small: comments, string and character literals and
preprocessor lines are blanked (newlines kept), then braces are matched. A block
opened after a head with parentheses, outside any function, is a function."""
import re
import sys
from pathlib import Path
from common import REPO

BINDINGS = REPO / "native" / "bindings"
MAX_LINES = 120

_CONTAINER = re.compile(r"^(template\s*<.*>\s*)?(inline\s+)?(namespace|struct|class|union|extern)\b", re.S)
_ENUM = re.compile(r"^(enum)\b")
_LAMBDA_NAME = re.compile(r"([A-Za-z_]\w*)\s*=\s*\[")
_CALL_NAME = re.compile(r"([A-Za-z_~][\w:]*)\s*(<[^()]*>)?\s*\($")


def blank_code(src: str) -> str:
    """src with comments, literals and preprocessor lines replaced by spaces (newlines kept)."""
    out = []
    i, n = 0, len(src)
    line_start = True
    while i < n:
        c = src[i]
        if line_start and c == "#" or (line_start and c in " \t" and src[i:].lstrip(" \t").startswith("#")):
            j = i
            while j < n:  # a directive runs to an unescaped newline
                k = src.find("\n", j)
                if k < 0:
                    k = n
                if k > 0 and src[k - 1] == "\\":
                    j = k + 1
                    continue
                break
            out.append(re.sub(r"[^\n]", " ", src[i:k]))
            i = k
            continue
        if src.startswith("//", i):
            k = src.find("\n", i)
            k = n if k < 0 else k
            out.append(" " * (k - i))
            i = k
            continue
        if src.startswith("/*", i):
            k = src.find("*/", i + 2)
            k = n if k < 0 else k + 2
            out.append(re.sub(r"[^\n]", " ", src[i:k]))
            i = k
            continue
        if c == "R" and src.startswith('R"', i):
            m = re.match(r'R"([^(\s]*)\(', src[i:])
            if m:
                end = src.find(")" + m.group(1) + '"', i)
                k = n if end < 0 else end + len(m.group(1)) + 2
                out.append('""' + re.sub(r"[^\n]", " ", src[i + 2:k]))
                i = k
                continue
        if c in "\"'" and not (c == "'" and i > 0 and src[i - 1].isalnum()):  # 1'000 is a number
            j = i + 1
            while j < n and src[j] != c and src[j] != "\n":
                j += 2 if src[j] == "\\" else 1
            k = min(j + 1, n)
            out.append(c + " " * max(0, k - i - 2) + c)
            i = k
            continue
        out.append(c)
        line_start = c == "\n" or (line_start and c in " \t")
        i += 1
    return "".join(out)


def _match(code: str, open_at: int) -> int:
    depth = 0
    for k in range(open_at, len(code)):
        if code[k] == "{":
            depth += 1
        elif code[k] == "}":
            depth -= 1
            if depth == 0:
                return k
    raise ValueError(f"unbalanced brace at offset {open_at}")


def _name(head: str) -> str | None:
    """The function a block head defines, or None when the block is no function."""
    if "(" not in head or head.endswith(("=", ",", "(")):
        return None
    lam = _LAMBDA_NAME.search(head)
    if lam and re.search(r"\]\s*(\(|\{|$|mutable|->)", head[lam.end() - 1:]):
        return lam.group(1) + " (lambda)"
    depth, cut = 0, None
    for k, ch in enumerate(head):  # the name ends at the first top-level '('
        if ch == "(":
            if depth == 0:
                cut = k
                break
            depth += 1
        elif ch == ")":
            depth -= 1
    m = _CALL_NAME.search(head[:cut + 1]) if cut is not None else None
    return m.group(1) if m else head[:cut].split()[-1] if cut else head.split()[0]


def functions(src: str) -> list[tuple[str, int, int]]:
    """(name, first line, length in lines) of every function defined outside a function."""
    code = blank_code(src)
    found = []

    def scan(lo: int, hi: int) -> None:
        head_at = lo
        k = lo
        while k < hi:
            ch = code[k]
            if ch == ";":
                head_at = k + 1
            elif ch == "}":
                head_at = k + 1
            elif ch == "{":
                close = _match(code, k)
                head = code[head_at:k].strip()
                first = code.count("\n", 0, head_at + (len(code[head_at:k]) - len(code[head_at:k].lstrip()))) + 1
                last = code.count("\n", 0, close) + 1
                if _CONTAINER.match(head) and not _ENUM.match(head):
                    scan(k + 1, close)
                else:
                    name = _name(head)
                    if name:
                        found.append((name, first, last - first + 1))
                k = close
                head_at = close + 1
            k += 1

    scan(0, len(code))
    return found


def too_long(paths, limit=MAX_LINES) -> list[str]:
    bad = []
    for p in paths:
        for name, line, length in functions(Path(p).read_text()):
            if length > limit:
                bad.append(f"{Path(p).name}:{line} {name}: {length} lines (limit {limit})")
    return bad


def _sources():
    return sorted([*BINDINGS.glob("*.cpp"), *BINDINGS.glob("*.hpp")])


def test_parser_finds_functions_lambdas_and_skips_literals():
    src = '\n'.join([
        "#include <x.hpp>",
        "namespace a { namespace {",
        "struct S { int f(int x) const {", "  return x; } };",
        'void g(py::module_& m) {', '  const char* s = "}{"; // }', "  /* { */ char c = '{';",
        "  m.def(\"h\", [](int y) { if (y) { return 1; } return 0; });", "}",
        "auto lam = [](int z) {", "  return z;", "};",
        "template <class T>", "T twice(T t) { return t + t; }",
        "enum class E { A, B };", "int table[] = {1, 2};",
        "}  // namespace", "}  // namespace a",
    ])
    got = {name: (line, length) for name, line, length in functions(src)}
    assert got == {"f": (3, 2), "g": (5, 5), "lam (lambda)": (10, 3), "twice": (13, 2)}


def test_parser_flags_a_long_function(tmp_path):
    body = "\n".join(f"  x += {i};" for i in range(MAX_LINES))
    f = tmp_path / "long.cpp"
    f.write_text(f"void bind_long(int x) {{\n{body}\n}}\nvoid short_one() {{}}\n")
    assert too_long([f]) == [f"long.cpp:1 bind_long: {MAX_LINES + 2} lines (limit {MAX_LINES})"]


def test_no_binding_function_is_too_long():
    sources = _sources()
    assert any(p.suffix == ".cpp" for p in sources), f"no binding sources under {BINDINGS}"
    bad = too_long(sources)
    assert not bad, "binding functions over the limit (split them into helpers):\n" + "\n".join(bad)


if __name__ == "__main__":  # python tests/cli/test_bindings_size.py [files...]: report, exit 1 when too long
    paths = sys.argv[1:] or _sources()
    bad = too_long(paths)
    print("\n".join(bad) or "ok")
    longest = max((f for p in paths for f in ((Path(p).name, *x) for x in functions(Path(p).read_text()))),
                  key=lambda f: f[3], default=None)
    if longest:
        print(f"longest: {longest[0]}:{longest[2]} {longest[1]} ({longest[3]} lines)")
    sys.exit(1 if bad else 0)
