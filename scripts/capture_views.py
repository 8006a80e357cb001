#!/usr/bin/env python3
"""Front views of a capture's isolated mesh and particles for the README (no numpy needed).

usage: capture_views.py MESH.ply PARTICLES_OR_DISPLACED.ply OUT_PREFIX [dx,dy,dz (view direction)]
       capture_views.py --side-by-side REST.png DEFORMED.png OUT.png
Writes OUT_PREFIX_mesh.png (vertices, shaded by depth: darker is nearer the camera) and
OUT_PREFIX_particles.png (rest positions grey, displaced positions red when the file has ux uy uz).
"""
import math
import struct
import sys
import zlib

TYPES = {'float': 'f', 'double': 'd', 'uchar': 'B', 'int': 'i', 'uint': 'I'}


def read_vertices(path):
    """Every vertex's properties as dicts, from a binary little-endian PLY."""
    with open(path, 'rb') as f:
        names, inside = [], False
        while True:
            line = f.readline().decode().strip()
            if line == 'end_header':
                break
            if line.startswith('element'):
                inside = line.startswith('element vertex')
                if inside:
                    count = int(line.split()[-1])
            elif inside and line.startswith('property'):
                names.append((line.split()[2], TYPES[line.split()[1]]))
        layout = '<' + ''.join(t for _, t in names)
        size = struct.calcsize(layout)
        data = f.read(count * size)
    return [dict(zip([n for n, _ in names], struct.unpack_from(layout, data, i * size))) for i in range(count)]


def write_png(path, pixels, width, height):
    """RGB pixels (list of tuples, row-major) as an 8-bit PNG."""
    raw = b''.join(b'\x00' + bytes(c for p in pixels[y * width:(y + 1) * width] for c in p) for y in range(height))

    def chunk(kind, body):
        return struct.pack('>I', len(body)) + kind + body + struct.pack('>I', zlib.crc32(kind + body) & 0xffffffff)
    header = struct.pack('>IIBBBBB', width, height, 8, 2, 0, 0, 0)
    with open(path, 'wb') as f:
        f.write(b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', header) + chunk(b'IDAT', zlib.compress(raw)) + chunk(b'IEND', b''))


class FrontView:
    """Orthographic view along -d (d points from the object to the cameras), z up."""

    def __init__(self, d, points, size=400):
        n = math.hypot(d[0], d[1])
        self.d, self.h, self.size = (d[0] / n, d[1] / n), (d[1] / n, -d[0] / n), size
        uz = [self.project(p) for p in points]
        self.lo = (min(u for u, _, _ in uz), min(z for _, z, _ in uz))
        self.span = 1.05 * max(max(u for u, _, _ in uz) - self.lo[0], max(z for _, z, _ in uz) - self.lo[1])
        self.depth = (min(t for _, _, t in uz), max(t for _, _, t in uz))

    def project(self, p):
        return (-(p[0] * self.h[0] + p[1] * self.h[1]), p[2], p[0] * self.d[0] + p[1] * self.d[1])

    def draw(self, pixels, nearest, p, colour, radius=0):
        u, z, t = self.project(p)
        x = int((u - self.lo[0]) / self.span * (self.size - 1))
        y = self.size - 1 - int((z - self.lo[1]) / self.span * (self.size - 1))
        for yy in range(max(0, y - radius), min(self.size, y + radius + 1)):
            for xx in range(max(0, x - radius), min(self.size, x + radius + 1)):
                if t > nearest[yy * self.size + xx]:
                    nearest[yy * self.size + xx] = t
                    pixels[yy * self.size + xx] = colour


def read_ppm(path):
    """A PNG decoded by `convert FILE.png ppm:-` (binary P6) as (width, height, RGB tuples)."""
    import subprocess
    data = subprocess.run(['convert', path, 'ppm:-'], check=True, capture_output=True).stdout
    fields, at = [], 0
    while len(fields) < 4:  # magic, width, height, maxval, separated by whitespace
        while data[at:at + 1].isspace():
            at += 1
        start = at
        while not data[at:at + 1].isspace():
            at += 1
        fields.append(data[start:at])
    w, h, body = int(fields[1]), int(fields[2]), data[at + 1:]
    return w, h, [tuple(body[3 * i:3 * i + 3]) for i in range(w * h)]


def side_by_side(left, right, out):
    """Two renders of one view next to each other (rest | deformed), a white 8 px gap."""
    (w, h, a), (w2, h2, b) = read_ppm(left), read_ppm(right)
    assert (w, h) == (w2, h2), 'the two renders differ in size'
    gap = [(255, 255, 255)] * 8
    rows = [a[y * w:(y + 1) * w] + gap + b[y * w:(y + 1) * w] for y in range(h)]
    write_png(out, [p for row in rows for p in row], 2 * w + 8, h)


def main():
    if sys.argv[1] == '--side-by-side':
        side_by_side(sys.argv[2], sys.argv[3], sys.argv[4])
        return
    mesh, cloud, prefix = read_vertices(sys.argv[1]), read_vertices(sys.argv[2]), sys.argv[3]
    d = [float(v) for v in sys.argv[4].split(',')] if len(sys.argv) > 4 else [0.922, -0.388, 0.0]
    points = [(v['x'], v['y'], v['z']) for v in mesh]
    view = FrontView(d, points)
    n = view.size
    pixels, nearest = [(255, 255, 255)] * (n * n), [-1e30] * (n * n)
    for p in points:
        shade = int(30 + 190 * (view.depth[1] - view.project(p)[2]) / ((view.depth[1] - view.depth[0]) or 1))
        view.draw(pixels, nearest, p, (shade, shade, min(255, shade + 30)))
    write_png(prefix + '_mesh.png', pixels, n, n)
    pixels, nearest = [(255, 255, 255)] * (n * n), [-1e30] * (n * n)
    for v in cloud:
        view.draw(pixels, nearest, (v['x'], v['y'], v['z']), (150, 150, 150), 1)
    if 'ux' in cloud[0]:  # the displaced cloud on top, nearer the viewer wins
        for v in cloud:
            view.draw(pixels, nearest, (v['x'] + v['ux'], v['y'] + v['uy'], v['z'] + v['uz'] + 1e-3), (200, 30, 30), 1)
    write_png(prefix + '_particles.png', pixels, n, n)


if __name__ == '__main__':
    main()
