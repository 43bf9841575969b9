#!/usr/bin/env python3
"""The repository's own ZUPT INS on foot-openshoe, rerun here: a plain-Python port (no numpy) of
OpenShoe_original's zero_velocity_detector.m (GLRT) and ZUPTaidedINS.m with the values of its
settings.m (the OpenShoe C port has the same values):
  detector  GLRT, sigma_a 0.01 m/s^2, sigma_g 0.1 deg/s, window 3 samples, gamma 5000; a window
            below gamma marks all its 3 samples as zero-velocity (non-causal, as the .m does)
  filter    9 states (position, velocity, attitude, NED), sigma_acc 0.5 m/s^2, sigma_gyro
            0.5 deg/s per sample, sigma_vel 0.01 m/s, P0 1e-5 m, 1e-5 m/s, 0.1 deg
  alignment roll and pitch from the first 20 samples, heading 0
  gravity   WGS84 at latitude 58 deg, 100 m (settings.m's gravity())
  Ts        1/820 s
Prints one line: samples, zero-velocity share, horizontal path length (between successive
positions sampled at 10 Hz, as scripts/realdata.d/foot-openshoe.sh measures ips-ins), the
distance from the end to the start, and the end position.
Usage: openshoe_reference.py OpenShoeDataSet.txt [--track FILE.csv]
"""
import math
import sys


def gravity(lat_deg, h):
    lam = math.radians(lat_deg)
    gam = 9.780327 * (1 + 0.0053024 * math.sin(lam) ** 2 - 0.0000058 * math.sin(2 * lam) ** 2)
    return gam - (3.0877e-6 - 0.004e-6 * math.sin(lam) ** 2) * h + 0.072e-12 * h * h


def matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def expm_skew(w):
    """Rotation matrix exp([w x]) (Rodrigues)."""
    th = math.sqrt(w[0] ** 2 + w[1] ** 2 + w[2] ** 2)
    if th < 1e-15:
        return [[1, -w[2], w[1]], [w[2], 1, -w[0]], [-w[1], w[0], 1]]
    k = [w[0] / th, w[1] / th, w[2] / th]
    s, c = math.sin(th), math.cos(th)
    v = 1 - c
    return [[c + k[0] * k[0] * v, k[0] * k[1] * v - k[2] * s, k[0] * k[2] * v + k[1] * s],
            [k[1] * k[0] * v + k[2] * s, c + k[1] * k[1] * v, k[1] * k[2] * v - k[0] * s],
            [k[2] * k[0] * v - k[1] * s, k[2] * k[1] * v + k[0] * s, c + k[2] * k[2] * v]]


def main():
    path = sys.argv[1]
    track_out = sys.argv[3] if len(sys.argv) > 3 and sys.argv[2] == "--track" else None
    u = []
    with open(path) as f:
        for line in f:
            p = line.strip().split(",")
            if len(p) >= 6:
                u.append([float(x) for x in p[:6]])
    n = len(u)
    ts = 1.0 / 820
    g = gravity(58.0, 100.0)
    sa2, sg2 = 0.01 ** 2, math.radians(0.1) ** 2
    W, gamma = 3, 5000.0

    # GLRT detector (zero_velocity_detector.m).
    zupt = [False] * n
    for k in range(n - W + 1):
        m = [sum(u[l][i] for l in range(k, k + W)) / W for i in range(3)]
        nm = math.sqrt(m[0] ** 2 + m[1] ** 2 + m[2] ** 2)
        t = 0.0
        for l in range(k, k + W):
            a = [u[l][i] - g * m[i] / nm for i in range(3)]
            t += (u[l][3] ** 2 + u[l][4] ** 2 + u[l][5] ** 2) / sg2 + (a[0] ** 2 + a[1] ** 2 + a[2] ** 2) / sa2
        if t / W < gamma:
            for l in range(k, k + W):
                zupt[l] = True

    # Initial alignment (init_Nav_eq): roll, pitch from the first 20 samples, heading 0.
    fu = sum(x[0] for x in u[:20]) / 20
    fv = sum(x[1] for x in u[:20]) / 20
    fw = sum(x[2] for x in u[:20]) / 20
    roll = math.atan2(-fv, -fw)
    pitch = math.atan2(fu, math.sqrt(fv * fv + fw * fw))
    yaw = 0.0
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))
    rt2b = [[cy * cp, sy * cp, -sp],
            [-sy * cr + cy * sp * sr, cy * cr + sy * sp * sr, cp * sr],
            [sy * sr + cy * sp * cr, -cy * sr + sy * sp * cr, cp * cr]]
    R = [[rt2b[j][i] for j in range(3)] for i in range(3)]  # body -> nav (NED)
    pos = [0.0, 0.0, 0.0]
    vel = [0.0, 0.0, 0.0]
    P = [[0.0] * 9 for _ in range(9)]
    for i in range(3):
        P[i][i] = 1e-5 ** 2
        P[3 + i][3 + i] = 1e-5 ** 2
        P[6 + i][6 + i] = math.radians(0.1) ** 2
    qa = (0.5 * ts) ** 2
    qg = (math.radians(0.5) * ts) ** 2
    rv = 0.01 ** 2

    every = 82  # 10 Hz at 820 Hz
    track = [(pos[0], pos[1])]
    for k in range(1, n):
        w = [u[k][3] * ts, u[k][4] * ts, u[k][5] * ts]
        R = matmul(R, expm_skew(w))
        f = [sum(R[i][j] * u[k][j] for j in range(3)) for i in range(3)]
        acc = [f[0], f[1], f[2] + g]
        for i in range(3):
            pos[i] += vel[i] * ts + 0.5 * ts * ts * acc[i]
            vel[i] += ts * acc[i]
        # P <- F P F' + G Q G', F = I + Ts Fc, Fc = [0 I 0; 0 0 [f x]; 0 0 0].
        St = [[0, -f[2], f[1]], [f[2], 0, -f[0]], [-f[1], f[0], 0]]
        FP = [row[:] for row in P]
        for j in range(9):
            for i in range(3):
                FP[i][j] += ts * P[3 + i][j]
                FP[3 + i][j] += ts * (St[i][0] * P[6][j] + St[i][1] * P[7][j] + St[i][2] * P[8][j])
        NP = [row[:] for row in FP]
        for i in range(9):
            for j in range(3):
                NP[i][j] += ts * FP[i][3 + j]
                NP[i][3 + j] += ts * (FP[i][6] * St[j][0] + FP[i][7] * St[j][1] + FP[i][8] * St[j][2])
        for i in range(3):
            NP[3 + i][3 + i] += qa
            NP[6 + i][6 + i] += qg
        P = [[0.5 * (NP[i][j] + NP[j][i]) for j in range(9)] for i in range(9)]
        if zupt[k]:
            S = [[P[3 + i][3 + j] + (rv if i == j else 0.0) for j in range(3)] for i in range(3)]
            det = (S[0][0] * (S[1][1] * S[2][2] - S[1][2] * S[2][1])
                   - S[0][1] * (S[1][0] * S[2][2] - S[1][2] * S[2][0])
                   + S[0][2] * (S[1][0] * S[2][1] - S[1][1] * S[2][0]))
            Si = [[(S[(j + 1) % 3][(i + 1) % 3] * S[(j + 2) % 3][(i + 2) % 3]
                    - S[(j + 1) % 3][(i + 2) % 3] * S[(j + 2) % 3][(i + 1) % 3]) / det
                   for j in range(3)] for i in range(3)]
            K = [[sum(P[i][3 + l] * Si[l][j] for l in range(3)) for j in range(3)] for i in range(9)]
            dx = [-(K[i][0] * vel[0] + K[i][1] * vel[1] + K[i][2] * vel[2]) for i in range(9)]
            for i in range(3):
                pos[i] += dx[i]
                vel[i] += dx[3 + i]
            e = dx[6:9]
            C = [[1, e[2], -e[1]], [-e[2], 1, e[0]], [e[1], -e[0], 1]]  # I - [e x]
            R = matmul(C, R)
            # Re-orthonormalise (dcm2q/q2dcm in the .m does the same through the quaternion).
            x, y = R[0], R[1]
            d = sum(x[i] * y[i] for i in range(3))
            x = [x[i] - 0.5 * d * y[i] for i in range(3)]
            y = [y[i] - 0.5 * d * R[0][i] for i in range(3)]
            z = [x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0]]
            R = [[c / math.sqrt(sum(v * v for v in r)) for c in r] for r in (x, y, z)]
            HP = [P[3 + i][:] for i in range(3)]
            P = [[P[i][j] - sum(K[i][l] * HP[l][j] for l in range(3)) for j in range(9)]
                 for i in range(9)]
            P = [[0.5 * (P[i][j] + P[j][i]) for j in range(9)] for i in range(9)]
        if k % every == 0:
            track.append((pos[0], pos[1]))
    track.append((pos[0], pos[1]))
    length = sum(math.dist(a, b) for a, b in zip(track, track[1:]))
    if track_out:
        with open(track_out, "w") as f:
            f.write("north_m,east_m\n")
            for a in track:
                f.write("%.4f,%.4f\n" % a)
    print("samples %d, zero-velocity %.1f%%, path %.2f m, end-start %.3f m, end N %.3f E %.3f D %.3f"
          % (n, 100.0 * sum(zupt) / n, length, math.dist(track[0], track[-1]), pos[0], pos[1], pos[2]))


if __name__ == "__main__":
    main()
