#!/usr/bin/env python3
"""Kloub's importer against the glTF-Validator's test corpus (github.com/KhronosGroup/glTF-Validator, `test/`,
kept outside this repository): every .gltf/.glb that has a `<file>.report.json` is opened with
`kloub inspect --json`, and the validator's verdict (errors or none) is set beside Kloub's (refused, loaded with
warnings, loaded silently).

    cargo build -p kloub-server && python3 scripts/conformance.py PATH/TO/glTF-Validator/test [--list]

Prints the counts the issue on real-world files tracks: valid files Kloub refuses, and invalid files it loads
without a word, each with the validator's error codes; `--list` names every such file.
"""
import collections
import json
import os
import subprocess
import sys

KLOUB = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'target', 'debug', 'kloub')


def main():
    args = [a for a in sys.argv[1:] if not a.startswith('--')]
    listing = '--list' in sys.argv
    if len(args) != 1:
        sys.exit(__doc__)
    files = []
    for folder, _, names in os.walk(args[0]):
        for name in names:
            if name.endswith(('.gltf', '.glb')) and os.path.exists(os.path.join(folder, name + '.report.json')):
                files.append(os.path.join(folder, name))
    files.sort()
    counts = collections.Counter()
    refused_valid, silent_invalid = [], []
    silent_codes = collections.Counter()
    for path in files:
        with open(path + '.report.json', encoding='utf-8') as f:
            report = json.load(f)
        errors = [m for m in report['issues']['messages'] if m['severity'] == 0]
        run = subprocess.run([KLOUB, 'inspect', '--json', path], capture_output=True, text=True, timeout=60)
        if run.returncode not in (0, 1) or 'panicked' in run.stderr:
            counts['crashed'] += 1
            print(f'CRASH {path}: {run.stderr.strip()[-300:]}')
            continue
        loaded = run.returncode == 0
        warnings = json.loads(run.stdout)['warnings'] if loaded else []
        verdict = 'valid' if not errors else 'invalid'
        outcome = 'refused' if not loaded else 'warned' if warnings else 'silent'
        counts[(verdict, outcome)] += 1
        rel = os.path.relpath(path, args[0])
        if verdict == 'valid' and outcome == 'refused':
            refused_valid.append((rel, run.stderr.strip().splitlines()[-1] if run.stderr.strip() else ''))
        if verdict == 'invalid' and outcome == 'silent':
            codes = sorted({m['code'] for m in errors})
            silent_invalid.append((rel, codes))
            silent_codes.update(codes)
    valid = sum(v for (k, _), v in counts.items() if k == 'valid')
    invalid = sum(v for (k, _), v in counts.items() if k == 'invalid')
    print(f'{len(files)} files: {valid} valid, {invalid} invalid (by the validator), {counts["crashed"]} crashed')
    print(f'valid:   {counts[("valid", "silent")]} loaded, {counts[("valid", "warned")]} loaded with warnings, '
          f'{counts[("valid", "refused")]} refused')
    print(f'invalid: {counts[("invalid", "refused")]} refused, {counts[("invalid", "warned")]} loaded with warnings, '
          f'{counts[("invalid", "silent")]} loaded without a warning')
    print('error codes of the invalid files loaded without a warning:')
    for code, n in silent_codes.most_common():
        print(f'  {n:4} {code}')
    if listing:
        print('valid files refused:')
        for rel, why in refused_valid:
            print(f'  {rel}: {why}')
        print('invalid files loaded without a warning:')
        for rel, codes in silent_invalid:
            print(f'  {rel}: {", ".join(codes)}')
    sys.exit(1 if counts['crashed'] else 0)


if __name__ == '__main__':
    main()
