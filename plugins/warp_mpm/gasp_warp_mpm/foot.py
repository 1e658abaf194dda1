"""Round 94 (issue 67 items 2 and 4; ``gasp_core.mpm.rigid_fit.side_foot``, ``docs/rigid.md`` "Round 94: a cylinder's
foot"): a rigid pair's normal impulse at a solid cylinder's foot, where its side bears on another rigid body's fitted
surface. The pair law pushes two bodies through their centres; a cylinder's side bears at the foot, off its middle
when it tilts on a curved body, and the moment of the push about its middle is what rights it (a board on a log).
Used by ``rigid_friction.rigid_pair`` (two bodies) and ``rigid_pairs.pair_update`` (three or more); taichi_mpm's
``foot.py`` is the same.

This module must not use ``from __future__ import annotations``: Warp reads the annotations of the functions below
as type objects.
"""
import warp as wp

from .rigid_support import Hollow, allowed_approach, mat33d, vec3d


@wp.func
def foot_arms(rnd: wp.array(dtype=wp.float64), hol: Hollow, a: int, b: int, RA: mat33d, RB: mat33d,
              foot: wp.float64):
    # the arms (m, world) of the normal impulse from each body's centre: the foot along the round body's axis (a
    # cylinder's, rigid_support.round_normal's foot), zero for the other body and wherever foot is 0
    armA = vec3d()
    armB = vec3d()
    if foot != wp.float64(0.0):
        if rnd[a] > wp.float64(0.0):
            armA = foot * (RA * hol.axis[a])
        else:
            armB = foot * (RB * hol.axis[b])
    return armA, armB


@wp.func
def foot_point(x_c: vec3d, cA: vec3d, cB: vec3d, armA: vec3d, armB: vec3d):
    # the contact point x_c moved along the round body's axis onto its foot (its arm's length from its centre); x_c
    # without an arm
    out = x_c
    if wp.length(armA) > wp.float64(0.0):
        e = wp.normalize(armA)
        out = x_c + armA - wp.dot(x_c - cA, e) * e
    elif wp.length(armB) > wp.float64(0.0):
        e = wp.normalize(armB)
        out = x_c + armB - wp.dot(x_c - cB, e) * e
    return out


@wp.func
def foot_approach(VA: vec3d, wA: vec3d, VB: vec3d, wB: vec3d, armA: vec3d, armB: vec3d, n: vec3d):
    # the approach along n (m/s) of A's point at the foot to B's (through the centres where the arms are zero)
    return wp.dot(VA + wp.cross(wA, armA) - VB - wp.cross(wB, armB), n)


@wp.func
def foot_push(VA: vec3d, wA: vec3d, VB: vec3d, wB: vec3d, MA: wp.float64, MB: wp.float64, iA: mat33d, iB: mat33d,
              armA: vec3d, armB: vec3d, n: vec3d, gap: wp.float64, dt: wp.float64):
    # the two-body law's normal impulse P (rigid_friction.rigid_pair; gasp_core.mpm.rigid_friction.pair_contact): the
    # approach at the foot less round 91's allowed one (allowed_approach) removed, the velocities and spins after it
    un = foot_approach(VA, wA, VB, wB, armA, armB, n)
    un = un - allowed_approach(gap, un, dt)
    P = wp.float64(0.0)
    if un > wp.float64(0.0):
        P = un / foot_mass(MA, MB, iA, iB, armA, armB, n)
    return VA - (P / MA) * n, wA - P * (iA * wp.cross(armA, n)), VB + (P / MB) * n, wB + P * (iB * wp.cross(armB, n)), P


@wp.func
def foot_mass(MA: wp.float64, MB: wp.float64, iA: mat33d, iB: mat33d, armA: vec3d, armB: vec3d, n: vec3d):
    # the inverse of the pair's effective mass along n at the foot (1 / MA + 1 / MB with zero arms)
    gA = wp.cross(armA, n)
    gB = wp.cross(armB, n)
    return wp.float64(1.0) / MA + wp.float64(1.0) / MB + wp.dot(gA, iA * gA) + wp.dot(gB, iB * gB)
