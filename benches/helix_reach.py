#!/usr/bin/env python3
"""How far G1 circular arcs and G1 helical elements reach along real curves.

A design measurement for the codec (issue 19: the hair at 0.5 mm), not a
benchmark of strandfit itself. Each curve is covered greedily from its start:
an element leaves the chain's end along its tangent and ends exactly at an
input vertex, as far along as it stays within `MARGIN * T` of the input
polyline both ways (input vertices to the element, the element's dense
samples to the input segments beside it); where no element reaches past the
next vertex, the tangent is reset to the input's (a corner, counted as half
an element). Arcs are the helices of pitch 0 (the codec's elements); helical
elements may take any of a grid of torsions (the previous element's first).
The codec quantises each end within the tolerance and so reaches further
than this sketch; the ratio of the two counts is what it measures.

Usage: python benches/helix_reach.py FILE.hair|FILE.tck T [--count N] [--margin M]
Curves are split by their mean turn per step (under 5, 5-15, over 15
degrees) and the first N of each kind measured.
"""
import argparse
import struct

import numpy as np
from scipy.optimize import fsolve

def load_hair(path):
    f=open(path,'rb').read()
    n,pc,arr=struct.unpack('<III',f[4:16])
    segs=np.frombuffer(f[128:128+2*n],dtype='<u2').astype(int)
    pts=np.frombuffer(f[128+2*n:128+2*n+12*pc],dtype='<f4').reshape(-1,3).astype(float)
    out=[];o=0
    for i in range(n):
        m=segs[i]+1; out.append(pts[o:o+m]); o+=m
    return out
def unit(v): return v/np.linalg.norm(v)
def perp(t):
    a=np.array([1.0,0,0]) if abs(t[0])<0.9 else np.array([0,1.0,0])
    n=np.cross(t,a); return unit(n)
def helix_pts(p0,t0,D,L,m=40):
    w=np.linalg.norm(D); s=np.linspace(0,L,m+1)
    if w<1e-12: return p0+np.outer(s,t0), t0
    a=D/w; ta=t0@a; tp=t0-ta*a; c=np.cross(a,tp)
    P=p0+np.outer(ta*s,a)+np.outer(np.sin(w*s)/w,tp)+np.outer((1-np.cos(w*s))/w,c)
    th=w*L; te=ta*a+np.cos(th)*tp+np.sin(th)*c
    return P, te
def seg_dist(P, A, B):
    # distance from each P to polyline A->B segments (A[k],B[k])
    d=B-A; dd=(d*d).sum(1); dd[dd==0]=1e-300
    w=P[:,None,:]-A[None]; t=np.clip((w*d[None]).sum(2)/dd[None],0,1)
    q=A[None]+t[...,None]*d[None]; return np.sqrt(((P[:,None,:]-q)**2).sum(2)).min(1)
def two_sided(H, pts, i, j):
    # covered input vertices i+1..j to helix polyline; helix samples to input window i-1..j+1
    n=len(pts)
    e1=seg_dist(pts[i+1:j+1], H[:-1], H[1:]).max()
    lo=max(i-1,0); hi=min(j+1,n-1)
    W=pts[lo:hi+1]
    e2=seg_dist(H[1:], W[:-1], W[1:]).max()
    return max(e1,e2)
def solve(p0,t0,p1,tau,guess):
    # unknowns phi, kappa, L ; D = kappa*(cos phi n1 + sin phi n2) + tau t0
    n1=perp(t0); n2=np.cross(t0,n1)
    def f(x):
        phi,k,L=x
        D=k*(np.cos(phi)*n1+np.sin(phi)*n2)+tau*t0
        P,_=helix_pts(p0,t0,D,L,1)
        return P[-1]-p1
    x,info,ier,msg=fsolve(f,guess,full_output=True)
    if ier!=1 or x[2]<=0 or np.linalg.norm(f(x))>1e-7: return None
    phi,k,L=x; D=k*(np.cos(phi)*n1+np.sin(phi)*n2)+tau*t0
    return D,L,x
def circle_guess(p0,t0,p1):
    d=p1-p0; c=np.linalg.norm(d); u=d/c
    ca=np.clip(t0@u,-1,1); al=np.arccos(ca)
    n1=perp(t0); n2=np.cross(t0,n1)
    nn=u-ca*t0
    if np.linalg.norm(nn)<1e-12: return np.array([0.0,1e-9,c])
    nn=unit(nn); phi=np.arctan2(nn@n2,nn@n1)
    k=2*np.sin(al)/c; L=c*al/np.sin(al) if al>1e-9 else c
    return np.array([phi,k,L])
TAUS=[0.0]+[s*x for x in (0.01,0.02,0.04,0.07,0.1,0.14,0.2,0.3) for s in (1,-1)]
def element(p0,t0,pts,i,j,Teff,helical,prev_tau):
    g=circle_guess(p0,t0,pts[j])
    taus=[0.0] if not helical else sorted(set(TAUS+[prev_tau]),key=lambda t:abs(t-prev_tau))
    best=None
    for tau in taus:
        r=solve(p0,t0,pts[j],tau,g)
        if r is None: continue
        D,L,x=r
        H,te=helix_pts(p0,t0,D,L,40)
        e=two_sided(H,pts,i,j)
        if e<=Teff:
            return (te,tau,e)
    return None
def ctan(pts,i):
    n=len(pts)
    if i==0: return unit(2*(pts[1]-pts[0])-(pts[2]-pts[0])/2) if n>2 else unit(pts[1]-pts[0])
    if i==n-1: return unit(pts[-1]-pts[-2])
    return unit(pts[i+1]-pts[i-1])
def reach(p,t,pts,i,Teff,helical,tau):
    n=len(pts); best=None; j=i+1
    while j<n:
        r=element(p,t,pts,i,j,Teff,helical,tau)
        if r is None: break
        best=(j,r); j+=1
    return best
def cover(pts,Teff,helical):
    n=len(pts); i=0; p=pts[0]; t=ctan(pts,0); count=0; tau=0.0
    while i<n-1:
        best=reach(p,t,pts,i,Teff,helical,tau)
        if best is None or best[0]<=i+1:
            # a corner: the tangent reset to the input's there
            t2=ctan(pts,i); b2=reach(p,t2,pts,i,Teff,helical,0.0)
            if b2 is not None and (best is None or b2[0]>best[0]): best=b2; count+=0.5
        if best is None:
            t=unit(pts[i+1]-p); best=(i+1,(t,0.0,0))
        j,(te,tau2,e)=best
        p=pts[j]; t=te; tau=tau2; i=j; count+=1
    return count

def load(path):
    if path.endswith('.hair'):
        return load_hair(path)
    import nibabel as nib
    return [np.asarray(s, dtype=float) for s in nib.streamlines.load(path).streamlines]


def mean_turn(p):
    d = np.diff(p, axis=0)
    t = d / np.linalg.norm(d, axis=1)[:, None]
    return np.degrees(np.arccos(np.clip((t[1:] * t[:-1]).sum(1), -1, 1))).mean()


if __name__ == '__main__':
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('file')
    ap.add_argument('tolerance', type=float)
    ap.add_argument('--count', type=int, default=20)
    ap.add_argument('--margin', type=float, default=0.6)
    a = ap.parse_args()
    curves = [c for c in load(a.file) if len(c) >= 3]
    teff = a.margin * a.tolerance
    for name, lo, hi in (('gentle (<5 deg/step)', 0, 5), ('wavy (5-15)', 5, 15), ('curly (>15)', 15, 180)):
        chosen = [c for c in curves if lo <= mean_turn(c) < hi][:a.count]
        if not chosen:
            continue
        arcs = sum(cover(c, teff, False) for c in chosen)
        helices = sum(cover(c, teff, True) for c in chosen)
        pts = sum(len(c) for c in chosen)
        print(f'{name:22s} {len(chosen):3d} curves {pts:6d} pts: arcs {arcs / len(chosen):6.1f} '
              f'helices {helices / len(chosen):6.1f} elements a curve (ratio {helices / arcs:.2f})', flush=True)
