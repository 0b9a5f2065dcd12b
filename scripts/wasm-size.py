#!/usr/bin/env python3
"""Code size of the web bundle per crate: sums twiggy's per-function sizes by the crate that owns each function.

    cargo install twiggy && python3 scripts/wasm-size.py target/wasm-bindgen/kloub_web_bg.wasm

Reads the wasm before wasm-opt (it still has function names). Prints one line per crate, largest first, and the
data segment (constants: fonts, tables) and the name section (stripped by wasm-opt, never shipped) separately.
"""
import collections
import csv
import io
import re
import signal
import subprocess
import sys

signal.signal(signal.SIGPIPE, signal.SIG_DFL)  # quiet under `| head`

path = sys.argv[1] if len(sys.argv) > 1 else 'target/wasm-bindgen/kloub_web_bg.wasm'
out = subprocess.run(['twiggy', 'top', '-f', 'csv', path], check=True, capture_output=True, text=True).stdout
sizes = collections.Counter()
for row in csv.DictReader(io.StringIO(out)):
    name, size = row['Name'], int(row['ShallowSize'])
    if name.startswith('"function names"') or name.startswith('"'):
        sizes['(name section, not shipped)' if 'names' in name else '(other sections)'] += size
    elif name.startswith('data segment'):
        sizes['(data: fonts, tables, strings)'] += size
    else:
        # The crate that owns a function: the first path segment, looking through `<T as Trait>` wrappers.
        m = re.search(r'([a-z_][a-z0-9_]*)::', name.lstrip('<&* '))
        crate = m.group(1) if m else '(unnamed: glue, std)'
        crate = {'core': 'std', 'alloc': 'std', 'std': 'std', 'hashbrown': 'std', 'compiler_builtins': 'std'}.get(crate, crate)
        sizes[crate] += size
total = sum(v for k, v in sizes.items() if 'not shipped' not in k)
print(f'{"bytes":>9}  {"share":>6}  crate  (of {total} bytes without the name section)')
for crate, size in sizes.most_common():
    share = '' if 'not shipped' in crate else f'{100 * size / total:5.1f}%'
    print(f'{size:>9}  {share:>6}  {crate}')
