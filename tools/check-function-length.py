#!/usr/bin/env python3
"""Lists the longest functions of the product's C++ and fails when one exceeds the limit.

The product is algo/, firmware/, hal/, host_sim/ and tools/ (tests/ is not). A function's length
is counted in lines from the first line of its declarator (after the previous declaration ends)
to its closing brace, both included. Lambdas and local classes count towards the function that
holds them; a lambda at namespace scope counts as a function of its own.

The scan blanks comments, string and character literals and preprocessor lines (keeping line
breaks), then matches braces: a brace opened at namespace or class scope after a declarator
ending in `)` (with qualifiers, a trailing return type or a constructor's initializer list)
opens a function. A file whose braces do not balance is an error, not a silent miscount.

usage: check-function-length.py SOURCE_DIR [--max N] [--top K]
           list the K longest functions (default 5) and every one over N lines (default 100);
           exit 1 if any is over N
       check-function-length.py --self-test
           prove the scan measures planted functions as written
"""
import argparse
import os
import re
import sys
import tempfile

PRODUCT_DIRS = ("algo", "firmware", "hal", "host_sim", "tools")
SOURCE_SUFFIXES = (".cpp", ".hpp", ".h", ".cc", ".ipp")
SKIP_DIRS = {".git", "build", "out", "__pycache__"}

IDENT_CHARS = re.compile(r"[A-Za-z0-9_]")
RAW_STRING_START = re.compile(r'(?:u8|u|U|L)?R"([^ ()\\\t\n]{0,16})\(')
# What may follow a function's parameter list before its body.
QUALIFIERS = re.compile(r"^(?:\s|const\b|volatile\b|noexcept\b(?:\s*\(\))?|override\b|final\b|mutable\b|&&|&|"
                        r"constexpr\b|consteval\b|->[^;]*|requires\b[^;]*|try\b)*$")
CONTAINER = re.compile(r"^\s*(?:template\s*<.*>\s*)?(?:namespace\b|extern\s*$|(?:class|struct|union)\b)", re.S)
ENUM = re.compile(r"^\s*(?:typedef\s+)?enum\b")
CONTROL = re.compile(r"^\s*(?:if|for|while|switch|catch|do|else)\b")


def blank(text):
    """Comments, string/char literals and preprocessor lines replaced by spaces (newlines kept)."""
    out = list(text)
    n = len(text)
    i = 0
    line_start = True  # only whitespace since the last newline

    def clear(a, b):
        for k in range(a, b):
            if out[k] != "\n":
                out[k] = " "

    while i < n:
        c = text[i]
        if c == "\n":
            line_start = True
            i += 1
            continue
        if line_start and c == "#":  # preprocessor line, with its continuations
            j = i
            while j < n and not (text[j] == "\n" and text[j - 1] != "\\"):
                j += 1
            clear(i, j)
            i = j
            continue
        if not c.isspace():
            line_start = False
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            clear(i, j)
            i = j
            continue
        if text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            clear(i, j)
            i = j
            continue
        m = RAW_STRING_START.match(text, i)
        if m and (i == 0 or not IDENT_CHARS.match(text[i - 1])):
            end = text.find(")" + m.group(1) + '"', m.end())
            j = n if end < 0 else end + len(m.group(1)) + 2
            clear(i, j)
            i = j
            continue
        if c == '"' or (c == "'" and not digit_separator(text, i)):
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            clear(i, min(j + 1, n))
            i = j + 1
            continue
        i += 1
    return "".join(out)


def digit_separator(text, i):
    """True for the ' in 864'000 (a number's digit separator), false for a character literal."""
    j = i
    while j > 0 and (IDENT_CHARS.match(text[j - 1]) or text[j - 1] in "'."):
        j -= 1
    return j < i and text[j].isdigit()


def bracket_depths(header):
    """(index, character, bracket depth after it) for every character of header."""
    depth = 0
    for k, c in enumerate(header):
        depth += 1 if c in "([" else -1 if c in ")]" else 0
        yield k, c, depth


def top_level_close_parens(header):
    """Indices of the ')' that close a parenthesis at bracket depth 0, in order."""
    return (k for k, c, depth in bracket_depths(header) if c == ")" and depth == 0)


def matching_open(header, close):
    depth = 0
    for k in range(close, -1, -1):
        if header[k] == ")":
            depth += 1
        elif header[k] == "(":
            depth -= 1
            if depth == 0:
                return k
    return -1


def constructor_params_close(header):
    """Index of the ')' ending a constructor's parameters when an initializer list follows."""
    for k in top_level_close_parens(header):
        rest = re.sub(r"^(?:noexcept\b|const\b|\s)*", "", header[k + 1:])
        if rest.startswith(":") and not rest.startswith("::"):
            return k
    return -1


def without_trailing_return(header):
    """header up to a trailing return type (auto f(T t) -> decltype(t + 1)), as written otherwise."""
    seen_params = False
    for k, c, depth in bracket_depths(header):
        seen_params = seen_params or (c == ")" and depth == 0)
        if seen_params and depth == 0 and header.startswith("->", k):
            return header[:k]
    return header


def function_name(header):
    """The function's (qualified) name, or None when the header does not open a function."""
    if CONTAINER.match(header) or ENUM.match(header) or CONTROL.match(header):
        return None
    if header.count("(") != header.count(")") or header.count("[") != header.count("]"):
        return None  # a brace inside an argument list: rng_(derive_seed(seed, {1}))
    header = without_trailing_return(header)
    close = constructor_params_close(header)
    if close < 0:
        close = max(top_level_close_parens(header), default=-1)
        if close < 0 or not QUALIFIERS.match(header[close + 1:]):
            return None
    before = header[:matching_open(header, close)].rstrip()
    lam = re.search(r"([A-Za-z_]\w*)\s*=\s*\[[^\]]*\]\s*$", before)
    if lam:
        return lam.group(1) + " (lambda)"
    name = re.search(r"((?:[A-Za-z_]\w*\s*(?:<[^<>]*>)?\s*::\s*)*~?(?:operator\s*(?:\(\)|[^\s(]+)|[A-Za-z_]\w*))$", before)
    return re.sub(r"\s+", "", name.group(1)) if name else None


def member_initializer(header):
    """True when the brace follows a name inside a constructor's initializer list (x_{1})."""
    tail = header.rstrip()
    return constructor_params_close(header) >= 0 and bool(tail) and (IDENT_CHARS.match(tail[-1]) or tail[-1] == ">")


def scan(code):
    """[(name, first_line, last_line)] of every function in blanked code; raises on bad braces."""
    functions = []
    stack = []  # per open brace: "container", "function", "block" or "init"
    header_start = 0
    line = 1
    line_of = []  # line number at each offset
    for c in code:
        line_of.append(line)
        if c == "\n":
            line += 1
    pending = None  # (name, start offset) of the function whose body is open
    depth_in_function = 0
    for k, c in enumerate(code):
        if pending is not None:
            if c == "{":
                depth_in_function += 1
            elif c == "}":
                depth_in_function -= 1
                if depth_in_function == 0:
                    functions.append((pending[0], line_of[pending[1]], line_of[k]))
                    pending = None
                    header_start = k + 1
            continue
        if c == ";":
            header_start = k + 1
        elif c == "{":
            header = code[header_start:k]
            if re.match(r"^\s*(?:public|private|protected)\s*:", header):
                header = re.sub(r"^\s*(?:public|private|protected)\s*:", "", header)
            name = function_name(header)
            if name is not None and member_initializer(header):
                name = None  # a member's braced initializer inside a constructor's initializer list
            if name is not None:
                first = header_start + len(header_start_ws(code, header_start, k))
                pending = (name, first)
                depth_in_function = 1
            elif CONTAINER.match(header) and "=" not in header.split("{")[0]:
                stack.append("container")
                header_start = k + 1
            else:
                stack.append("init")  # braced initializer or enum: part of the declaration
        elif c == "}":
            if not stack:
                raise ValueError("unbalanced '}' on line %d" % line_of[k])
            kind = stack.pop()
            if kind == "container":
                header_start = k + 1
        elif c == ":" and re.search(r"(?:public|private|protected)\s*$", code[header_start:k]) \
                and not code.startswith("::", k) and code[k - 1] != ":":
            header_start = k + 1
    if pending is not None or stack:
        raise ValueError("unbalanced '{' (end of file inside a scope)")
    return functions


def header_start_ws(code, start, end):
    m = re.match(r"\s*", code[start:end])
    return m.group(0)


def walk(root):
    for top in PRODUCT_DIRS:
        for dirpath, dirnames, filenames in os.walk(os.path.join(root, top)):
            dirnames[:] = sorted(d for d in dirnames if d not in SKIP_DIRS)
            for f in sorted(filenames):
                if f.endswith(SOURCE_SUFFIXES):
                    yield os.path.join(dirpath, f)


def measure_tree(root):
    """[(lines, path, line, name)] of every function, and the files that failed to scan."""
    rows, errors = [], []
    for path in walk(root):
        rel = os.path.relpath(path, root)
        with open(path, encoding="utf-8", errors="replace") as f:
            text = f.read()
        try:
            for name, first, last in scan(blank(text)):
                rows.append((last - first + 1, rel, first, name))
        except ValueError as e:
            errors.append("%s: %s" % (rel, e))
    rows.sort(key=lambda r: (-r[0], r[1], r[2]))
    return rows, errors


def self_test():
    planted = r'''#include <string>
#define BRACE {
namespace a { namespace {
extern "C" {
const char* kText = "}{ \"{\" ";  // } a comment brace
}
constexpr int kBig = 864'000;
struct S {
  int x{1};
  S() : x{2}, y(std::max({1, 2})) {
    x = 3;
  }
  int get() const noexcept { return x; }
  int y;
};
enum class E { kA, kB };
auto twice = [](int v) {
  return 2 * v;
};
}  // namespace
/* { */ int f(int n) {
  if (n > 0) {
    char q = '{';
    return R"x(})x"[0] + q;
  }
  return 0;
}
template <typename T>
auto g(T t) -> decltype(t + 1) {
  return t + 1;
}
}  // namespace a
'''
    expected = [("S", 10, 12), ("get", 13, 13), ("twice (lambda)", 17, 19), ("f", 21, 27), ("g", 28, 31)]
    got = scan(blank(planted))
    ok = got == expected
    if not ok:
        print("self-test: want %s\n           got  %s" % (expected, got))
    for bad in ("int f() {\n", "int f() {}\n}\n"):
        try:
            scan(blank(bad))
            print("self-test: unbalanced braces not reported: %r" % bad)
            ok = False
        except ValueError:
            pass
    with tempfile.TemporaryDirectory() as root:
        os.makedirs(os.path.join(root, "tools"))
        os.makedirs(os.path.join(root, "tests"))
        long_body = "int long_one() {\n" + "  ;\n" * 101 + "}\n"
        for rel in ("tools/x.cpp", "tests/x.cpp"):
            with open(os.path.join(root, rel), "w") as f:
                f.write(long_body)
        rows, errors = measure_tree(root)
        if rows != [(103, os.path.join("tools", "x.cpp"), 1, "long_one")] or errors:
            print("self-test: tree scan gave %s %s" % (rows, errors))
            ok = False
    print("self-test: " + ("ok" if ok else "FAILED"))
    return 0 if ok else 1


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("source_dir", nargs="?")
    parser.add_argument("--max", type=int, default=100, help="longest allowed function, lines")
    parser.add_argument("--top", type=int, default=5, help="how many of the longest to list")
    parser.add_argument("--self-test", action="store_true")
    args = parser.parse_args(argv)
    if args.self_test:
        return self_test()
    if not args.source_dir:
        parser.error("SOURCE_DIR is required")
    rows, errors = measure_tree(args.source_dir)
    print("%d functions in %s; the %d longest:" % (len(rows), ", ".join(d + "/" for d in PRODUCT_DIRS), args.top))
    for lines, rel, line, name in rows[:args.top]:
        print("  %4d  %s:%d  %s" % (lines, rel, line, name))
    over = [r for r in rows if r[0] > args.max]
    for lines, rel, line, name in over:
        print("OVER %d: %4d lines  %s:%d  %s" % (args.max, lines, rel, line, name))
    for e in errors:
        print("CANNOT SCAN: " + e)
    if over or errors:
        print("%d function(s) over %d lines, %d file(s) not scanned" % (len(over), args.max, len(errors)))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
