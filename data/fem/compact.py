"""Compacts an output folder of ipc_sphere_contact.py into the form kept in the repository.

A geometric deformer is compared with the simulation on the contact side only, so only that part of
each step is kept (see README.md):

  reference.txt      key = value lines: scene, radii and rest centres of A (and B), material, command
  summary.csv        the simulation's summary, as written
  rest_A.obj         A's whole rest surface (the deformer's input), positions with 7 digits
  cap_A.txt          the rest vertex ids (0-based, increasing) of A's contact side: the vertices within
                     the polar angle min(pi/2, 3 R_min / R_A) + 0.15 rad of the contact axis
  step_NNN_A.obj     the deformed positions of those vertices (v lines only, in cap order; the faces
                     are rest_A's faces whose three vertices are in the cap)
  and the same for B in the scene `spheres`.

usage: python compact.py OUT_DIR DEST_DIR --command "the command that made OUT_DIR"
"""
import argparse, csv, os, shutil
import numpy as np


def read_obj(path):
    V, F = [], []
    with open(path) as f:
        for line in f:
            if line.startswith('v '):
                V.append([float(x) for x in line.split()[1:4]])
            elif line.startswith('f '):
                F.append([int(x.split('/')[0]) - 1 for x in line.split()[1:4]])
    return np.asarray(V), np.asarray(F, dtype=np.int64)


def write_obj(path, V, F=None):
    with open(path, 'w') as f:
        f.write(''.join(f'v {a:.7g} {b:.7g} {c:.7g}\n' for a, b, c in V))
        if F is not None:
            f.write(''.join(f'f {i + 1} {j + 1} {k + 1}\n' for i, j, k in F))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('src'); ap.add_argument('dest'); ap.add_argument('--command', required=True)
    ap.add_argument('--dhat', type=float, default=1e-3)
    args = ap.parse_args()
    os.makedirs(args.dest, exist_ok=True)
    bodies = ['A'] + (['B'] if os.path.exists(os.path.join(args.src, 'rest_B.obj')) else [])
    rest = {b: read_obj(os.path.join(args.src, f'rest_{b}.obj')) for b in bodies}
    # Rest centres as the script places them: A above z = 0, B below, dhat/2 from it.
    radius = {b: 0.5 * (rest[b][0][:, 2].max() - rest[b][0][:, 2].min()) for b in bodies}
    gap0 = 0.5 * args.dhat
    centre = {'A': np.array([0.0, 0.0, radius['A'] + gap0])}
    if 'B' in bodies:
        centre['B'] = np.array([0.0, 0.0, -radius['B'] - gap0])
    toward = {'A': np.array([0.0, 0.0, -1.0]), 'B': np.array([0.0, 0.0, 1.0])}   # from the centre to the contact
    r_min = min(radius.values())
    with open(os.path.join(args.dest, 'reference.txt'), 'w') as f:
        f.write(f"scene = {'spheres' if 'B' in bodies else 'plane'}\n")
        for b in bodies:
            f.write(f'radius_{b} = {radius[b]:.9g}\n')
            f.write(f'centre_{b} = {centre[b][0]:.9g} {centre[b][1]:.9g} {centre[b][2]:.9g}\n')
        f.write('young_modulus = 1e5\npoisson_ratio = 0.45\n')
        f.write(f'dhat = {args.dhat:g}\n')
        f.write(f'command = {args.command}\n')
    shutil.copy(os.path.join(args.src, 'summary.csv'), os.path.join(args.dest, 'summary.csv'))
    steps = sorted(int(n[5:8]) for n in os.listdir(args.src) if n.startswith('step_') and n.endswith('_A.obj'))
    for b in bodies:
        V, F = rest[b]
        write_obj(os.path.join(args.dest, f'rest_{b}.obj'), V, F)
        cosines = ((V - centre[b]) @ toward[b]) / np.linalg.norm(V - centre[b], axis=1)
        limit = min(0.5 * np.pi, 3.0 * r_min / radius[b]) + 0.15
        cap = np.where(cosines >= np.cos(limit))[0]
        with open(os.path.join(args.dest, f'cap_{b}.txt'), 'w') as f:
            f.write(' '.join(str(i) for i in cap) + '\n')
        for k in steps:
            X, _ = read_obj(os.path.join(args.src, f'step_{k:03d}_{b}.obj'))
            write_obj(os.path.join(args.dest, f'step_{k:03d}_{b}.obj'), X[cap])


if __name__ == '__main__':
    main()
