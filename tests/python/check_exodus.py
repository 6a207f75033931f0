#!/usr/bin/env python3
"""An independent reader of mbdc's `results.exo`: opens it with the netCDF4 package
(libnetcdf, not mbdc's code) and checks the Exodus II structure ParaView's reader relies
on, and the values given on the command line (exactly: they are printed by the Rust test
in a form that parses back to the same double).

    check_exodus.py FILE --nodes N --elements E --frames F --elem-type HEX8
        [--connect-first 1,2,...] [--time FRAME:T] [--nodal NAME:FRAME:NODE:VALUE]
        [--element NAME:BLOCK:FRAME:ELEMENT:VALUE]

Nodes, elements and blocks are 0-based except BLOCK, which is Exodus's 1-based number.
Exit code 0 when every check holds; 1 with the failed checks on stderr.
"""
import argparse
import sys

import netCDF4
import numpy as np


def names(ds, var):
    return [str(s).strip() for s in netCDF4.chartostring(ds.variables[var][:])]


def main():
    p = argparse.ArgumentParser()
    p.add_argument("file")
    p.add_argument("--nodes", type=int, required=True)
    p.add_argument("--elements", type=int, required=True)
    p.add_argument("--frames", type=int, required=True)
    p.add_argument("--elem-type", required=True)
    p.add_argument("--connect-first")
    p.add_argument("--time", action="append", default=[])
    p.add_argument("--nodal", action="append", default=[])
    p.add_argument("--element", action="append", default=[])
    a = p.parse_args()
    failed = []

    def check(ok, what):
        print(("ok   " if ok else "FAIL ") + what)
        if not ok:
            failed.append(what)

    ds = netCDF4.Dataset(a.file, "r")
    ds.set_auto_mask(False)
    check(ds.data_model == "NETCDF3_64BIT_OFFSET", f"format {ds.data_model}")
    for attr in ["api_version", "version", "floating_point_word_size", "file_size", "title"]:
        check(attr in ds.ncattrs(), f"global attribute {attr}")
    check(int(ds.floating_point_word_size) == 8, "floating_point_word_size = 8")
    dims = ds.dimensions
    check(dims["time_step"].isunlimited(), "time_step is unlimited")
    check(len(dims["num_dim"]) == 3, "num_dim = 3")
    check(len(dims["num_nodes"]) == a.nodes, f"num_nodes = {a.nodes} ({len(dims['num_nodes'])})")
    check(len(dims["num_elem"]) == a.elements, f"num_elem = {a.elements} ({len(dims['num_elem'])})")
    check(len(dims["time_step"]) == a.frames, f"time_step = {a.frames} ({len(dims['time_step'])})")
    nblk = len(dims["num_el_blk"])
    total = sum(len(dims[f"num_el_in_blk{k}"]) for k in range(1, nblk + 1))
    check(total == a.elements, "blocks hold num_elem elements")
    c1 = ds.variables["connect1"]
    check(c1.elem_type == a.elem_type, f"connect1 elem_type {c1.elem_type}")
    conn = c1[:]
    check(conn.min() >= 1 and conn.max() <= a.nodes, "connectivity is 1-based within the nodes")
    if a.connect_first:
        want = [int(x) for x in a.connect_first.split(",")]
        check(list(conn[0]) == want, f"connect1[0] = {want} ({list(conn[0])})")
    for v in ["coordx", "coordy", "coordz", "eb_prop1", "eb_status", "time_whole", "vals_glo_var"]:
        check(v in ds.variables, f"variable {v}")
    check(np.all(np.diff(ds.variables["time_whole"][:]) > 0), "times increase")
    nod = names(ds, "name_nod_var")
    elem = names(ds, "name_elem_var")
    for spec in a.time:
        f, t = spec.split(":")
        got = float(ds.variables["time_whole"][int(f)])
        check(got == float(t), f"time[{f}] = {t} ({got!r})")
    for spec in a.nodal:
        name, f, n, x = spec.split(":")
        i = nod.index(name) + 1
        got = float(ds.variables[f"vals_nod_var{i}"][int(f), int(n)])
        check(got == float(x), f"{name}[{f}, {n}] = {x} ({got!r})")
    for spec in a.element:
        name, b, f, e, x = spec.split(":")
        i = elem.index(name) + 1
        tab = ds.variables["elem_var_tab"][:]
        check(tab[int(b) - 1, i - 1] == 1, f"truth table has {name} in block {b}")
        got = float(ds.variables[f"vals_elem_var{i}eb{b}"][int(f), int(e)])
        check(got == float(x), f"{name}[block {b}, {f}, {e}] = {x} ({got!r})")
    ds.close()
    if failed:
        print(f"{len(failed)} check(s) failed", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
