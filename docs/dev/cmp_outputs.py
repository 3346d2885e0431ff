"""NRMSE of simulated outputs against a measured record, every row: python3 cmp_outputs.py MEASURED.csv SIM.csv...
(SIM from `geared-servo --params P.toml simulate --input MEASURED.csv --output SIM.csv`). A dev probe."""
import csv,math,sys
def load(f):
    r=list(csv.reader(l for l in open(f) if not l.startswith('#')))
    h=r[0];return h,[list(map(float,x)) for x in r[1:]]
hm,m=load(sys.argv[1])
for f in sys.argv[2:]:
    hs,s=load(f)
    out=[]
    for col in ['tach_voltage_v','load_angle_deg']:
        if col not in hm: continue
        im=hm.index(col); is_=hs.index(col)
        y=[x[im] for x in m]; yy=[x[is_] for x in s]
        n=min(len(y),len(yy)); e=[y[k]-yy[k] for k in range(n)]
        rms=lambda v: math.sqrt(sum(t*t for t in v)/len(v))
        mu=sum(y)/n
        out.append('%s %.4f'%(col[:4], rms(e)/rms([t-mu for t in y[:n]])))
    print(f, *out)
