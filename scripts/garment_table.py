#!/usr/bin/env python3
# The table of docs/garments.md ("Any garment") from a raycloth batch output folder of
# scenes/sweeps/garmentcode_all_short.json, garmentcode_all.json or garment_pattern_generator_short.json
# (gc: GarmentCode, gcd: GarmentCodeData, gpg: the older generator): python3 scripts/garment_table.py OUT
import json, os, sys
root = sys.argv[1]
rows = []
for l in open(os.path.join(root, 'results.jsonl')):
    j = json.loads(l)
    name = j['values']['/garments/0/garmentcode'].split('/')
    fam = {'garmentcodedata': 'gcd', 'garment-pattern-generator': 'gpg'}.get(name[-2], 'gc')
    f = name[-1].replace('_specification.json', '')
    case = os.path.join(root, 'cases', j['id'])
    seams = welded = stitches = None; first_bad = None; stand_bad = walk_bad = None; verts = None; cross_close = None
    try:
        r = json.load(open(os.path.join(case, 'run.json')))
        s = r.get('seams', {})
        welded, stitches = s.get('welded'), s.get('stitches')
        gap = s.get('largest_gap_at_end')
        fr = r['frames']
        verts = r['vertices']
        stand = [x for x in fr if x['time'] <= 1.0 + 1e-9]
        walk = [x for x in fr if x['time'] > 1.0 + 1e-9]
        bad = lambda x: x.get('crossings', 0) > 0 or x.get('vertices_inside', 0) > 0
        stand_bad = sum(bad(x) for x in stand); walk_bad = sum(bad(x) for x in walk)
        cross_close = max([x.get('crossings', 0) for x in fr if x['time'] <= 0.5 + 1e-9] or [0])
        cross_after = max([x.get('crossings', 0) for x in fr if 0.5 < x['time'] <= 1.0 + 1e-9] or [0])
        inside_walk = max([x.get('vertices_inside', 0) for x in walk] or [0])
    except Exception as e:
        gap = None; cross_after = inside_walk = None
    rows.append((j['id'], fam + '/' + f, verts, j['status'], j['frames'], j['bad_frames'], stand_bad, cross_close, cross_after, walk_bad, inside_walk, welded, stitches, gap, j.get('steps_per_second'), j.get('wall_s'), (j.get('error') or '')[:90]))
print('| case | file | cloth vertices | bad frames / frames | standing (0-1 s): bad frames, most crossings while sewing (<= 0.5 s), after | walking (after 1 s): bad frames, most vertices inside | stitches welded | widest seam gap at the end | steps/s | wall s |')
print('|---|---|---:|---:|---|---|---:|---:|---:|---:|')
for r in sorted(rows):
    (i, f, v, st, fr, bf, sb, cc, ca, wb, iw, w, n, g, sps, wall, err) = r
    print(f"| {i} | {f} | {v} | {bf} / {fr} | {sb}: {cc}, {ca} | {wb}: {iw} | {w} / {n} | {'' if g is None else f'{g*1000:.1f} mm'} | {sps} | {wall} |")
