#!/usr/bin/env python3
"""A lead for the accel_kin floor, not a fitted effect: how far the Vicon attitude strays from the
gyro's in flight, and whether the raw accel_kin residual follows it.

    python3 scripts/nanobench-attitude.py data/nanobench/dataset/*.csv

δθ = ∫(ω_vicon − ω_gyro)dt with its 0.5 s moving average removed (over that long the gyro's
integral holds; what is left is the Vicon attitude's error at higher frequencies), body frame
(FLU as logged). A Vicon attitude error δθ makes the mocap's specific force f̂ = Rᵀ(p̈ + g·e_z)
wrong by −δθ × f ≈ (−g·δθ_y, g·δθ_x) in flight, so the accelerometer-minus-f̂ residual follows
g·δθ_y in x and −g·δθ_x in y with slope 1 where that error dominates. The residual here is the
raw one (smoothed like identify's, σ = 20 ms; no effect fitted): a lever arm or an offset is
still in it. For scale, the last column is the same g·σ_θ of the Vicon attitude at rest (the
leading rows with the motors off, smoothed alike). Pure Python, a few seconds for ten flights.
"""
import csv, math, sys

G = 9.81
def gauss(x, s=2.0):
    h=int(3*s); k=[math.exp(-0.5*(i/s)**2) for i in range(-h,h+1)]; z=sum(k); k=[v/z for v in k]
    n=len(x); return [sum(k[j]*x[i+j-h] for j in range(len(k))) if h<=i<n-h else x[i] for i in range(n)]
def qmul(a,b):
    ax,ay,az,aw=a; bx,by,bz,bw=b
    return (aw*bx+ax*bw+ay*bz-az*by, aw*by-ax*bz+ay*bw+az*bx, aw*bz+ax*by-ay*bx+az*bw, aw*bw-ax*bx-ay*by-az*bz)
def conj(q): return (-q[0],-q[1],-q[2],q[3])
def rotT(q,v):  # R^T v, R body->world
    qv=(v[0],v[1],v[2],0.0); r=qmul(qmul(conj(q),qv),q); return r[:3]
def logq(q):
    x,y,z,w=q
    if w<0: x,y,z,w=-x,-y,-z,-w
    s=math.sqrt(x*x+y*y+z*z); a=2*math.atan2(s,w)
    return (0,0,0) if s<1e-12 else (a*x/s,a*y/s,a*z/s)
def movavg(x,w):
    n=len(x); h=w//2; c=[0.0]
    for v in x: c.append(c[-1]+v)
    return [(c[min(n,i+h+1)]-c[max(0,i-h)])/(min(n,i+h+1)-max(0,i-h)) for i in range(n)]
def corr(a,b):
    n=len(a); ma=sum(a)/n; mb=sum(b)/n
    sab=sum((x-ma)*(y-mb) for x,y in zip(a,b)); saa=sum((x-ma)**2 for x in a); sbb=sum((y-mb)**2 for y in b)
    return sab/math.sqrt(saa*sbb), sab/sbb
for f in sys.argv[1:]:
    rows=list(csv.DictReader(open(f))); n=len(rows); dt=0.01
    P=[[float(r[k]) for r in rows] for k in ('px','py','pz')]
    Q=[(float(r['qx']),float(r['qy']),float(r['qz']),float(r['qw'])) for r in rows]
    A=[[G*float(r[k]) for r in rows] for k in ('imu_acc_x','imu_acc_y','imu_acc_z')]
    W=[[float(r[k]) for r in rows] for k in ('imu_gyro_x','imu_gyro_y','imu_gyro_z')]
    air=[float(r['pz'])>0.15 for r in rows]
    Ps=[gauss(p) for p in P]; As=[gauss(a) for a in A]
    fh=[None]*n
    for i in range(1,n-1):
        acc=[(Ps[k][i+1]-2*Ps[k][i]+Ps[k][i-1])/dt**2 for k in range(3)]
        acc[2]+=G
        fh[i]=rotT(Q[i],acc)
    # mocap body rates
    wm=[[0.0]*n for _ in range(3)]
    for i in range(1,n-1):
        d=logq(qmul(conj(Q[i-1]),Q[i+1]))
        for k in range(3): wm[k][i]=d[k]/(2*dt)
    # attitude error: integral of mocap − gyro rate, high-passed (0.5 s moving average removed)
    th=[]
    for k in range(3):
        c=0.0; s=[]
        for i in range(n): c+=(wm[k][i]-W[k][i])*dt; s.append(c)
        ma=movavg(s,51); th.append(gauss([a-b for a,b in zip(s,ma)]))
    fhs=[gauss([fh[i][k] if fh[i] else 0.0 for i in range(n)]) for k in range(3)]
    idx=[i for i in range(60,n-60) if all(air[i-30:i+30])]
    rx=[As[0][i]-fhs[0][i] for i in idx]; ry=[As[1][i]-fhs[1][i] for i in idx]
    mx=sum(rx)/len(rx); my=sum(ry)/len(ry)
    ex=[G*th[1][i] for i in idx]; ey=[-G*th[0][i] for i in idx]
    cx,bx=corr(rx,ex); cy,by=corr(ry,ey)
    sd=lambda v: math.sqrt(sum((x-sum(v)/len(v))**2 for x in v)/len(v))
    rxr=[a-mx-bx*(e-sum(ex)/len(ex)) for a,e in zip(rx,ex)]
    rest = [i for i in range(n) if all(float(rows[i][f'motor_motor_m{k}']) == 0 for k in range(1, 5))]
    rest = rest[: next((j for j, i in enumerate(rest) if i != j), len(rest))]  # the leading run
    still = lambda key: sd([v for v in gauss([float(rows[i][key]) for i in rest])[6:-6]]) * G if len(rest) > 20 else float('nan')
    print(f"{f.split('/')[-1][:-4]:24s} n={len(idx)} resid x sd {sd(rx):.3f} y {sd(ry):.3f} | g·δθ sd x {sd(ex):.3f} y {sd(ey):.3f} | r x {cx:+.2f} slope {bx:+.2f}; y {cy:+.2f} slope {by:+.2f} | x left {sd(rxr):.3f} | at rest g·σθ x {still('pitch'):.4f} y {still('roll'):.4f}")
