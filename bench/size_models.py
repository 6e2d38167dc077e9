#!/usr/bin/env python3
"""Model files of realistic size for issue #31 (derivatives by automatic differentiation).

  size_models.py DIR                    writes one YAML model file per case into DIR
  size_models.py --first-parameter FILE prints NAME=VALUE of FILE's first parameter (for a sweep)
  size_models.py --peer NAME            the SymPy pipeline on case NAME (needs sympy and numpy)

The cases grow where GiNaC's expanded derivatives blow up: products of sums, long sums, many
coordinates as energies and as bodies, loop closures through atan2 and sqrt. Standard library
only, except --peer. Expressions are written in double quotes, so that commas (atan2) and leading
signs never meet YAML's syntax, and sums are joined with " + " or " - ", so that the peer can
split them without Python's parser recursing once per term."""
import os
import re
import sys
import threading
from itertools import accumulate

MM, BB = [["2", "1"], ["1", "1"]], [["1"], ["0"]]  # the two-coordinate model of the issue


def two_coordinate(name, params, force):
    return dict(name=name, kind="multibody", params=[("k", 5.0)] + params, coords=["x", "s"],
                mass_matrix=MM, forces=["0", force], input_matrix=BB, outputs=["x + s"])


def product_of_sums(k):
    params, sums = [], []
    for i in range(1, k + 1):  # a_i, b_i, c_i, d_i distinct: no two sums alike
        params += [(p + str(i), round(base + 0.01 * i, 4)) for p, base in
                   (("a", 0.1), ("b", 0.2), ("c", 0.3), ("d", 0.4))]
        sums.append("(a%d*x + b%d*s + c%d*s_dot + d%d*x_dot + 1)" % (i, i, i, i))
    return two_coordinate("product_of_sums_%d" % k, params, "k*s + 1e-3*" + "*".join(sums))


def sum_of_terms(n):
    # Term j is c_j x^a s^b x_dot^e s_dot^f with (a, b, e, f) the digits of j in base E: distinct
    # monomials, so GiNaC can merge none of them, with exponents below 18 even at N = 10^5.
    base = next(b for b in range(2, 100) if b ** 4 > n)
    names, terms = ("x", "s", "x_dot", "s_dot"), []
    for j in range(1, n + 1):
        digits = [j // base ** p % base for p in range(4)]
        factors = [v if e == 1 else "%s^%d" % (v, e) for v, e in zip(names, digits) if e]
        terms.append("*".join([str(1 + j % 9)] + factors))
    return two_coordinate("sum_of_terms_%d" % n, [], "k*s + 1e-6*(" + " + ".join(terms) + ")")


def pendulum_chain(n):
    # n point masses m on massless rods l, absolute angles th_i from the downward vertical,
    # torsion springs c and dampers d between neighbouring rods, torque on rod 1, output the
    # horizontal position of rod 2's middle (the tip's gives P = 0: at rest a torque on rod 1
    # moves mass 1 across rod 2, which mass 2 does not feel). Mass i moves with velocity
    # l sum_{j<=i} th_j_dot (cos th_j, sin th_j), so T = m l^2/2 sum_{j,k} (n + 1 - max(j, k))
    # cos(th_j - th_k) th_j_dot th_k_dot: n^2/2 terms, the dense M of a real serial chain.
    th = ["th%d" % i for i in range(1, n + 1)]
    t = ["m*l^2/2*%d*%s_dot^2" % (n - j, th[j]) for j in range(n)]
    t += ["m*l^2*%d*cos(%s - %s)*%s_dot*%s_dot" % (n - k, th[j], th[k], th[j], th[k])
          for k in range(n) for j in range(k)]
    v = ["m*g*l*%d*cos(%s)" % (n - j, th[j]) for j in range(n)]
    v += ["c/2*(%s - %s)^2" % (th[j], th[j - 1]) for j in range(1, n)]
    r = ["d/2*(%s_dot - %s_dot)^2" % (th[j], th[j - 1]) for j in range(1, n)]
    return dict(name="pendulum_chain_%d" % n, kind="lagrangian", coords=th,
                params=[("m", 1.0), ("l", 0.5), ("g", 9.81), ("c", 20.0), ("d", 0.1)],
                T=" + ".join(t), V="-" + " - ".join(v[:n]) + " + " + " + ".join(v[n:]),
                R=" + ".join(r), input_matrix=[["1"]] + [["0"]] * (n - 1),
                outputs=["l*sin(th1) + l/2*sin(th2)"])


def planar_arm(n):
    # The shipped three-link arm with n links (Table 2 values, horizontal plane): relative joint
    # angles q_i, link i's absolute angle q_1 + ... + q_i, pointing along +y at q = 0 so that
    # the output, the x coordinate of link 2's end, has a nonzero gradient there. Joint 1
    # driven, the rest passive. Not the tip's x: a torque on link 1 reaches link k's
    # acceleration only through a factor of about 2 - sqrt(3) = 0.268 per link (P = 6.7e-6 at
    # 10 links, 1.3e-11 at 20), so at 50 links P = H M^-1 B is 1e-28, below rounding.
    q = ["q%d" % i for i in range(1, n + 1)]
    ang = ["(" + " + ".join(q[:i + 1]) + ")" for i in range(n)]
    bodies = []
    for i in range(n):
        xs = ["l*sin(%s)" % a for a in ang[:i]] + ["l/2*sin(%s)" % ang[i]]
        ys = ["l*cos(%s)" % a for a in ang[:i]] + ["l/2*cos(%s)" % ang[i]]
        bodies.append(("link%d" % (i + 1), "-" + " - ".join(xs), " + ".join(ys), ang[i]))
    return dict(name="planar_arm_%d" % n, kind="planar-bodies", coords=q, bodies=bodies,
                params=[("m", 3.438), ("l", 1.0), ("c", 50.0), ("d", 0.25)], passive=q[1:],
                outputs=["-" + " - ".join("l*sin(%s)" % a for a in ang[:2])])


def five_bar():
    # Ground pivots A = (0, 0), E = (w, 0); cranks AB (l1, driven) and ED (l4, passive: spring c,
    # damper d), upright at q = 0: B = (-l1 sin q1, l1 cos q1), D = (w - l4 sin q2, l4 cos q2).
    # Loop closure (elbow up): C = B + (a dx - h dy, a dy + h dx)/|BD|, (dx, dy) = D - B,
    # a = (l2^2 - l3^2 + |BD|^2)/(2 |BD|), h = sqrt(l2^2 - a^2); phi2, phi3 the angles of BC, DC.
    # B + l2 e(phi2) = D + l3 e(phi3) differentiated gives the coupler rates
    # w2 = (D' - B').e(phi3)/(l2 sin(phi3 - phi2)), w3 = (B' - D').e(phi2)/(l3 sin(phi2 - phi3)).
    # Uniform rods: T = m l^2/6 q'^2 per crank, m/2 |G'|^2 + m l^2/24 w^2 per coupler, with
    # |G2'|^2 = l1^2 q1'^2 + l2 w2 l1 q1' sin(phi2 - q1) + l2^2/4 w2^2, alike for link 3
    # (checked against finite differences of the positions to 1e-9).
    bx, by, ex, ey = "(-l1*sin(q1))", "(l1*cos(q1))", "(w - l4*sin(q2))", "(l4*cos(q2))"
    dx, dy = "(%s - %s)" % (ex, bx), "(%s - %s)" % (ey, by)
    dd2 = "(%s^2 + %s^2)" % (dx, dy); dd = "sqrt%s" % dd2  # noqa: E702
    a = "((l2^2 - l3^2 + %s)/(2*%s))" % (dd2, dd)
    h, a3 = "sqrt(l2^2 - %s^2)" % a, "(%s - %s)" % (a, dd)
    phi2 = "atan2(%s*%s + %s*%s, %s*%s - %s*%s)" % (a, dy, h, dx, a, dx, h, dy)
    phi3 = "atan2(%s*%s + %s*%s, %s*%s - %s*%s)" % (a3, dy, h, dx, a3, dx, h, dy)
    w2 = "((l1*q1_dot*cos(q1 - %s) - l4*q2_dot*cos(q2 - %s))/(l2*sin(%s - %s)))" % (
        phi3, phi3, phi3, phi2)
    w3 = "((l4*q2_dot*cos(q2 - %s) - l1*q1_dot*cos(q1 - %s))/(l3*sin(%s - %s)))" % (
        phi2, phi2, phi2, phi3)
    t = ["m1*l1^2/6*q1_dot^2", "m4*l4^2/6*q2_dot^2",
         "m2/2*l1^2*q1_dot^2", "m2/2*l2*l1*q1_dot*sin(%s - q1)*%s" % (phi2, w2),
         "m2*l2^2/6*%s^2" % w2,  # m2 l2^2/8 + m2 l2^2/24
         "m3/2*l4^2*q2_dot^2", "m3/2*l3*l4*q2_dot*sin(%s - q2)*%s" % (phi3, w3),
         "m3*l3^2/6*%s^2" % w3]
    return dict(name="five_bar", kind="lagrangian", coords=["q1", "q2"], T=" + ".join(t),
                params=list(zip("l1 l2 l3 l4 w m1 m2 m3 m4 c d".split(),
                                (1.0, 1.5, 1.5, 1.0, 2.0, 1.0, 1.5, 1.5, 1.0, 10.0, 0.1))),
                V="c/2*q2^2", R="d/2*q2_dot^2", input_matrix=BB,
                outputs=["%s + (%s*%s - %s*%s)/%s" % (bx, a, dx, h, dy, dd)])


def elastic_joint_arm():
    # The index-5 robot-arm benchmark of issue #31: two links (point masses m1 at the elbow, m2
    # at the tip), joint 1 driven directly, joint 2 driven through an elastic transmission (rotor
    # inertia Jm, angle th2 relative to link 1, stiffness k), link 2 bent by 90 degrees at q = 0,
    # gravity along -y, the end point (x, y) prescribed. u1 and u2 reach the links' accelerations
    # only as u1 - u2 (the rotor's reaction on link 1), so the decoupling matrix is singular
    # everywhere and a dynamic extension runs: flat, differentiation index 5.
    tip_rate = "l1^2*q1_dot^2 + l2^2*(q1_dot + q2_dot)^2 - 2*l1*l2*sin(q2)*q1_dot*(q1_dot + q2_dot)"
    return dict(name="elastic_joint_arm", kind="lagrangian", coords=["q1", "q2", "th2"],
                params=[("m1", 1.0), ("m2", 0.8), ("l1", 0.5), ("l2", 0.4), ("Jm", 0.01),
                        ("k", 50.0), ("g", 9.81)],
                T="m1/2*l1^2*q1_dot^2 + m2/2*(%s) + Jm/2*(q1_dot + th2_dot)^2" % tip_rate,
                V="m1*g*l1*sin(q1) + m2*g*(l1*sin(q1) + l2*cos(q1 + q2)) + k/2*(th2 - q2)^2",
                R=None, input_matrix=[["1", "0"], ["0", "0"], ["0", "1"]],
                inputs=["u1", "u2"],
                outputs=["l1*cos(q1) - l2*sin(q1 + q2)", "l1*sin(q1) + l2*cos(q1 + q2)"])


CASES = {"product_of_sums_%d" % k: (product_of_sums, k) for k in range(2, 11)}
CASES.update({"sum_of_terms_%d" % n: (sum_of_terms, n) for n in (1000, 4000, 100000)})
CASES.update({"pendulum_chain_%d" % n: (pendulum_chain, n) for n in (10, 50, 100, 400)})
CASES.update({"planar_arm_%d" % n: (planar_arm, n) for n in (10, 20, 50)})
CASES["five_bar"] = (five_bar,)
CASES["elastic_joint_arm"] = (elastic_joint_arm,)
build = lambda name: CASES[name][0](*CASES[name][1:])  # noqa: E731


def to_yaml(m):
    q = lambda e: '"%s"' % e  # noqa: E731
    rows = lambda rs: "".join("  - [%s]\n" % ", ".join(map(q, r)) for r in rs)  # noqa: E731
    out = ["# generated by bench/size_models.py (issue #31); do not edit\n",
           "kind: %s\nname: %s\nparameters:\n" % (m["kind"], m["name"])]
    out += ["  %s: %r\n" % p for p in m["params"]]
    out.append("coordinates: [%s]\ninputs: [%s]\n" % (", ".join(m["coords"]),
                                                       ", ".join(m.get("inputs", ["u"]))))
    if m["kind"] == "multibody":
        out.append("mass_matrix:\n" + rows(m["mass_matrix"]))
        out.append("forces:\n" + "".join("  - %s\n" % q(f) for f in m["forces"]))
    elif m["kind"] == "lagrangian":
        out += ["%s: %s\n" % (k, q(m[key])) for k, key in
                (("kinetic_energy", "T"), ("potential_energy", "V"), ("dissipation", "R"))
                if m.get(key) is not None]
    else:
        out += ["bodies:\n"] + ["  %s:\n    mass: m\n    inertia: m*l^2/12\n    position:\n"
                                "      - %s\n      - %s\n    angle: %s\n" % (b, q(x), q(y), q(a))
                                for b, x, y, a in m["bodies"]]
        out += ["springs:\n"] + ["  - {coordinate: %s, stiffness: c, rest: 0}\n" % c
                                 for c in m["passive"]]
        out += ["dampers:\n"] + ["  - {coordinate: %s, damping: d}\n" % c for c in m["passive"]]
        out.append("actuators:\n  u: {on: link1, torque: 1}\n")
    if "input_matrix" in m:
        out.append("input_matrix:\n" + rows(m["input_matrix"]))
    out.append("outputs:\n" + "".join("  - %s\n" % q(h) for h in m["outputs"]))
    return "".join(out)


def first_parameter(path):
    text = open(path).read()
    match = re.search(r"^parameters:\s*(?:#.*)?\n\s+(\w+):\s*([^#\n]+)", text, re.M) or \
        re.search(r"^parameters:\s*\{\s*(\w+):\s*([^,}]+)", text, re.M)
    print("%s=%s" % (match.group(1), match.group(2).strip().replace(" ", "")))


def peer(name):
    # What a SymPy user would write: parse the model's expressions, derive M and f from the
    # energies where the file gives energies (Lagrange's equations, as servokit does), take the
    # Jacobian of f in (q, q_dot) with sympy.diff (Matrix.jacobian, nothing expanded), lambdify
    # M and the Jacobian and evaluate them once at q = 0, q_dot = 0.1 with the file's parameters.
    import sympy
    from sympy.parsing.sympy_parser import convert_xor, parse_expr, standard_transformations as st
    m = build(name)
    q = [sympy.Symbol(c) for c in m["coords"]]
    qd = [sympy.Symbol(c + "_dot") for c in m["coords"]]
    params = [sympy.Symbol(p) for p, _ in m["params"]]
    local = {str(s): s for s in q + qd + params}
    rules = st + (convert_xor,)

    def split(text, seps):  # the pieces between separators at depth 0, each with its separator
        pieces, depth, start, i = [], 0, 0, 0
        while i < len(text):
            depth += {"(": 1, ")": -1}.get(text[i], 0)
            sep = next((x for x in seps if depth == 0 and i and text.startswith(x, i)), "")
            if sep:
                pieces.append(text[start:i])
                start = i
            i += len(sep) or 1
        return pieces + [text[start:]]

    def parse(text):  # sums and long products split in O(terms); parse_expr on the rest
        text = text.strip()
        terms = split(text, (" + ", " - "))
        if len(terms) > 1:
            return sympy.Add(*[(-1 if t[:3] == " - " else 1) *
                               parse(t[3:] if t[:3] in (" + ", " - ") else t) for t in terms])
        factors = split(text, ("*",))
        if len(factors) > 1 and len(text) > 200:
            return sympy.Mul(*[parse(f.lstrip("*")) for f in factors])
        depths = list(accumulate({"(": 1, ")": -1}.get(c, 0) for c in text))
        if text[:1] == "(" and 0 not in depths[:-1]:  # one parenthesis around it all
            return parse(text[1:-1])
        return parse_expr(text, local_dict=local, transformations=rules)

    if m["kind"] == "multibody":
        f = sympy.Matrix([parse(e) for e in m["forces"]])
        mass = sympy.Matrix([[parse(e) for e in row] for row in m["mass_matrix"]])
    else:
        if m["kind"] == "lagrangian":
            t, v = parse(m["T"]), parse(m["V"])
            r = parse(m["R"]) if m.get("R") else sympy.Integer(0)
        else:  # bodies: T = sum m/2 |J_r q_dot|^2 + J/2 (d angle/dq . q_dot)^2
            mm, ll, cc, dd = params
            t = 0
            for _, x, y, angle in m["bodies"]:
                r_dot = sympy.Matrix([parse(x), parse(y)]).jacobian(q) * sympy.Matrix(qd)
                w = sum(sympy.diff(parse(angle), a) * b for a, b in zip(q, qd))
                t += mm / 2 * (r_dot.T * r_dot)[0] + mm * ll ** 2 / 24 * w ** 2
            v = sum(cc / 2 * local[c] ** 2 for c in m["passive"])
            r = sum(dd / 2 * local[c + "_dot"] ** 2 for c in m["passive"])
        p = sympy.Matrix([sympy.diff(t, a) for a in qd])
        mass = p.jacobian(qd)
        f = p.jacobian(q) * sympy.Matrix(qd) - sympy.Matrix(
            [sympy.diff(t, a) - sympy.diff(v, a) - sympy.diff(r, b) for a, b in zip(q, qd)])
    jac = f.jacobian(q + qd)
    evaluate = sympy.lambdify(q + qd + params, [mass, jac], "numpy")
    values = evaluate(*([0.0] * len(q) + [0.1] * len(q) + [float(x) for _, x in m["params"]]))
    print("%s: M %dx%d, df/d(q, q_dot) %dx%d, |J|_1 = %.6g" % (
        name, mass.rows, mass.cols, jac.rows, jac.cols, abs(values[1]).sum()))


def main():
    if sys.argv[1] == "--first-parameter":
        return first_parameter(sys.argv[2])
    if sys.argv[1] == "--peer":  # lambdify's code for a long sum nests deeply: a deep stack
        sys.setrecursionlimit(10 ** 6)
        threading.stack_size(512 << 20)
        worker = threading.Thread(target=peer, args=(sys.argv[2],))
        return worker.start() or worker.join()
    os.makedirs(sys.argv[1], exist_ok=True)
    for name in CASES:
        path = os.path.join(sys.argv[1], name + ".yaml")
        with open(path, "w") as f:
            f.write(to_yaml(build(name)))
        print(path)


if __name__ == "__main__":
    main()
