#!/usr/bin/env python3
"""Print the longest Rust functions (lines from `fn` to its closing brace)."""
import argparse, os, re, subprocess, sys

FN = re.compile(r'^\s*(?:pub(?:\([^)]*\))?\s+)?(?:const\s+)?(?:async\s+)?(?:unsafe\s+)?(?:extern\s+"[^"]*"\s+)?fn\s+(\w+)')

def strip(line, state):
    """Remove comments, strings and char literals; state carries block comments."""
    out, i, n = [], 0, len(line)
    while i < n:
        if state['block']:
            j = line.find('*/', i)
            if j < 0: return ''.join(out)
            state['block'] = False; i = j + 2; continue
        c = line[i]
        if line.startswith('//', i): break
        if line.startswith('/*', i): state['block'] = True; i += 2; continue
        if c == '"':
            i += 1
            while i < n and line[i] != '"':
                i += 2 if line[i] == '\\' else 1
            i += 1; continue
        if c == "'":
            m = re.match(r"'(\\.|[^\\'])'", line[i:]) or re.match(r"'\\u\{[0-9a-fA-F]+\}'", line[i:]) or re.match(r"'\\x[0-9a-fA-F]{2}'", line[i:])
            if m: i += len(m.group(0)); continue
        out.append(c); i += 1
    return ''.join(out)

def functions(path):
    with open(path, encoding='utf-8', errors='replace') as f:
        lines = f.read().split('\n')
    state = {'block': False}
    clean = [strip(l, state) for l in lines]
    for idx, l in enumerate(clean):
        m = FN.match(l)
        if not m: continue
        depth, started = 0, False
        for j in range(idx, len(clean)):
            for ch in clean[j]:
                if ch == ';' and not started and depth == 0: break
                if ch == '{': depth += 1; started = True
                elif ch == '}': depth -= 1
            else:
                if started and depth == 0:
                    yield m.group(1), idx + 1, j - idx + 1; break
                continue
            break  # declaration without body

def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument('--top', type=int, default=10)
    ap.add_argument('--exclude', action='append', default=['firmware/', 'emulator/'])
    a = ap.parse_args()
    files = subprocess.run(['git', 'ls-files', '*.rs'], capture_output=True, text=True, check=True).stdout.split()
    rows = []
    for p in files:
        if any(p.startswith(e) for e in a.exclude): continue
        rows += [(n, p, s, name) for name, s, n in functions(p)]
    rows.sort(reverse=True)
    for n, p, s, name in rows[:a.top]:
        print(f'{n:4d}  {p}:{s}  {name}')

if __name__ == '__main__':
    try: main()
    except BrokenPipeError: sys.exit(0)
