import json, os, sys
base = json.load(open(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'inputs', 'paper.json')))
base['sample']['count'] = 1000
base['description'] = 'rate ladder scene: 1000 spheres of the paper, TTC to e1 = 5 %, tests at the paper dt'
base['prepare']['time_step'] = 1.0e-6
ttc = base['tests'][0]
ttc['end']['strain'] = 0.05
ttc['time_step'] = 1.0e-6
base['control_failure'] = 'warn'
base['tests'] = [ttc]
def deck(f, state=None):
    d = json.loads(json.dumps(base))
    t = d['tests'][0]
    t['axes']['x1']['strain_increment'] = 2.0e-7 * f
    t['output_interval'] = max(1, round(1000 / f))
    if state:
        d.pop('prepare'); d['initial_state'] = state
    return d
json.dump(deck(1.0), open('ladder_1x_prep.json', 'w'), indent=1)
for s in (1, 2):
    for f in (0.25, 0.5, 2, 4, 8, 1.001, 1.002):
        json.dump(deck(f, f'prep/seed-{s}/prepared.state'), open(f'ladder_s{s}_{f}.json', 'w'), indent=1)
