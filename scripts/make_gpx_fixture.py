#!/usr/bin/env python3
"""Makes tests/data/kitti_gps_head.gpx from real GPS positions.

Takes the first 40 rows of tests/data/KittiGps_converted.txt (GPS of the
drive behind KITTI 00, `Time,X,Y,Z` in metres), reads (X, Y, Z) minus the
first row as east-north-up metres around an origin near Karlsruhe (where
KITTI was recorded), converts them back to WGS84 latitude, longitude and
ellipsoidal height, and writes a GPX 1.1 track. `Time` becomes a UTC time of
day on 2011-10-03 (the KITTI 00 recording date).

This inverse (ENU -> ECEF -> geodetic, Bowring's iteration) is written
independently of the Rust reader, so reading the GPX back must give
(X - X0, Y - Y0, Z - Z0) to well under a millimetre.

Run from the repository root: python3 scripts/make_gpx_fixture.py
"""
import datetime
import math

A = 6378137.0
F = 1 / 298.257223563
E2 = F * (2 - F)
ORIGIN = (48.982545, 8.390366, 116.38)  # lat deg, lon deg, height m
ROWS = 40


def ecef(lat, lon, h):
    phi, lam = math.radians(lat), math.radians(lon)
    n = A / math.sqrt(1 - E2 * math.sin(phi) ** 2)
    return ((n + h) * math.cos(phi) * math.cos(lam),
            (n + h) * math.cos(phi) * math.sin(lam),
            (n * (1 - E2) + h) * math.sin(phi))


def geodetic(x, y, z):
    lam = math.atan2(y, x)
    p = math.hypot(x, y)
    phi = math.atan2(z, p * (1 - E2))
    for _ in range(10):
        n = A / math.sqrt(1 - E2 * math.sin(phi) ** 2)
        h = p / math.cos(phi) - n
        phi = math.atan2(z, p * (1 - E2 * n / (n + h)))
    n = A / math.sqrt(1 - E2 * math.sin(phi) ** 2)
    h = p / math.cos(phi) - n
    return math.degrees(phi), math.degrees(lam), h


def enu_to_geodetic(e, n_, u):
    phi, lam = math.radians(ORIGIN[0]), math.radians(ORIGIN[1])
    sp, cp, sl, cl = math.sin(phi), math.cos(phi), math.sin(lam), math.cos(lam)
    x0, y0, z0 = ecef(*ORIGIN)
    # ECEF offset = R^T (e, n, u), R's rows being the east, north, up axes.
    dx = -sl * e - sp * cl * n_ + cp * cl * u
    dy = cl * e - sp * sl * n_ + cp * sl * u
    dz = cp * n_ + sp * u
    return geodetic(x0 + dx, y0 + dy, z0 + dz)


def main():
    with open("tests/data/KittiGps_converted.txt") as f:
        rows = [list(map(float, l.split(","))) for l in f.read().splitlines()[1:1 + ROWS]]
    t0, x0, y0, z0 = rows[0]
    day = datetime.datetime(2011, 10, 3, tzinfo=datetime.timezone.utc)
    out = ['<?xml version="1.0" encoding="UTF-8"?>',
           '<gpx version="1.1" creator="turnprint scripts/make_gpx_fixture.py" '
           'xmlns="http://www.topografix.com/GPX/1/1">',
           '  <trk>', '    <name>KITTI 00 GPS, first %d fixes</name>' % ROWS, '    <trkseg>']
    for t, x, y, z in rows:
        lat, lon, h = enu_to_geodetic(x - x0, y - y0, z - z0)
        stamp = (day + datetime.timedelta(seconds=t)).isoformat(timespec="microseconds")
        stamp = stamp.replace("+00:00", "Z")
        out.append('      <trkpt lat="%.10f" lon="%.10f">' % (lat, lon))
        out.append('        <ele>%.4f</ele>' % h)
        out.append('        <time>%s</time>' % stamp)
        out.append('      </trkpt>')
    out += ['    </trkseg>', '  </trk>', '</gpx>', '']
    with open("tests/data/kitti_gps_head.gpx", "w") as f:
        f.write("\n".join(out))


if __name__ == "__main__":
    main()
