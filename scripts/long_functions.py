"""The house check of issue 17: every Rust function longer than LIMIT lines (default 150) in
core/, io/, cli/ and ffi/ (or the folders given), longest first. Brace matching with strings
and line comments skipped; run from the repository root: python3 scripts/long_functions.py."""
import re, sys, pathlib
LIMIT = int(sys.argv[1]) if len(sys.argv) > 1 else 150
roots = sys.argv[2:] or ["core", "io", "cli", "ffi"]
fn_re = re.compile(r'^\s*(pub(\([^)]*\))?\s+)?(const\s+)?(async\s+)?(unsafe\s+)?(extern\s+"C"\s+)?fn\s+(\w+)')
out = []
for root in roots:
    for p in pathlib.Path(root).rglob("*.rs"):
        if "target" in p.parts: continue
        lines = p.read_text().split("\n")
        i = 0
        while i < len(lines):
            m = fn_re.match(lines[i])
            if m:
                name = m.group(7); start = i; depth = 0; seen = False; j = i
                while j < len(lines):
                    code = re.sub(r'//.*', '', lines[j])
                    code = re.sub(r'"(\\.|[^"\\])*"', '""', code)
                    code = re.sub(r"'(\\.|[^'\\])'", "''", code)
                    depth += code.count("{") - code.count("}")
                    if "{" in code: seen = True
                    if seen and depth <= 0: break
                    if not seen and code.rstrip().endswith(";"): break
                    j += 1
                n = j - start + 1
                if n > LIMIT:
                    out.append((n, f"{p}:{start+1}", name))
                i = i + 1
            else:
                i += 1
for n, loc, name in sorted(out, reverse=True):
    print(f"{n:5d}  {loc}  {name}")
