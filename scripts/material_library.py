#!/usr/bin/env python3
# Writes the shipped material graph library scenes/materials/*.mtlx (issue 17):
# python3 scripts/material_library.py scenes/materials
# and its compute-heavy variant (every position/texcoord domain-warped by two
# 8-octave vector3 fractal3d layers, every fractal six octaves more, up to 16;
# the thesis's Classroom graphs dominate its frame time):
# python3 scripts/material_library.py scenes/materials/heavy --heavy
import os, sys
OUT = sys.argv[1]
HEAVY = sys.argv[2:] == ['--heavy']
class N:
    def __init__(s, name, ty): s.name, s.ty = name, ty
def F(x): return ('float', f'{x}')
def I(x): return ('integer', f'{x}')
def V2(a,b): return ('vector2', f'{a}, {b}')
def V3(a,b,c): return ('vector3', f'{a}, {b}, {c}')
def C3(a,b,c): return ('color3', f'{a}, {b}, {c}')
class G:
    def __init__(s, name, doc):
        if HEAVY:
            name, doc = name + '_heavy', 'Compute-heavy variant (domain warp, more octaves) of: ' + doc
        s.name, s.doc, s.lines, s.n, s.outs = name, doc, [], {}, []
        s.warping = False
    def __getattr__(s, cat):
        if cat.startswith('__'):
            raise AttributeError(cat)
        def mk(ty, **inputs):
            node = mk_plain(ty, **inputs)
            if HEAVY and cat in ('position', 'texcoord') and not s.warping:
                s.warping = True
                node = warp(s, node)
                s.warping = False
            return node
        def mk_plain(ty, **inputs):
            k = s.n.get(cat, 0) + 1; s.n[cat] = k
            name = f'{cat}{k}'
            body = []
            for iname, v in inputs.items():
                iname = iname.rstrip('_')
                if isinstance(v, N):
                    body.append(f'      <input name="{iname}" type="{v.ty}" nodename="{v.name}" />')
                else:
                    body.append(f'      <input name="{iname}" type="{v[0]}" value="{v[1]}" />')
            if body:
                s.lines.append(f'    <{cat} name="{name}" type="{ty}">\n' + "\n".join(body) + f'\n    </{cat}>')
            else:
                s.lines.append(f'    <{cat} name="{name}" type="{ty}" />')
            return N(name, ty)
        return mk
    def out(s, name, node):
        s.outs.append(f'    <output name="{name}" type="{node.ty}" nodename="{node.name}" />')
    def write(s):
        text = ('<?xml version="1.0"?>\n<materialx version="1.39">\n'
                f'  <!-- {s.doc} -->\n  <nodegraph name="{s.name}">\n'
                + "\n".join(s.lines) + "\n" + "\n".join(s.outs) + '\n  </nodegraph>\n</materialx>\n')
        open(os.path.join(OUT, s.name + '.mtlx'), 'w').write(text)
        print(s.name, len(s.lines), 'nodes')

def warp(g, p):
    # Two layers of domain warping by a vector3 fractal (8 octaves each).
    p3 = p if p.ty == 'vector3' else g.combine3('vector3', in1=g.extract('float', in_=p, index=I(0)), in2=g.extract('float', in_=p, index=I(1)), in3=F(0.0))
    for k in range(2):
        q = g.multiply('vector3', in1=p3, in2=F(2.0 + k))
        w = g.fractal3d('vector3', position=q, octaves=I(8), amplitude=F(1.0), lacunarity=F(2.0), diminish=F(0.5))
        p3 = g.add('vector3', in1=p3, in2=g.multiply('vector3', in1=w, in2=F(0.02)))
    if p.ty == 'vector3':
        return p3
    return g.combine2('vector2', in1=g.extract('float', in_=p3, index=I(0)), in2=g.extract('float', in_=p3, index=I(1)))

def fbm(g, p, octaves, freq, amp=1.0):
    if HEAVY:
        octaves = min(16, octaves + 6)
    q = g.multiply('vector3', in1=p, in2=F(freq))
    return g.fractal3d('float', position=q, octaves=I(octaves), amplitude=F(amp), lacunarity=F(2.0), diminish=F(0.5))

def hnormal(g, height, scale):
    # MaterialX's heighttonormal scales the gradient by 1/16 (Sobel parity):
    # 16x keeps the relief of normalize(-scale*grad h, 1) these were made for.
    hn = g.heighttonormal('vector3', in_=height, scale=F(16.0 * scale))
    return g.normalmap('vector3', in_=hn)

# 1 bricks ---------------------------------------------------------------
g = G('bricks', 'Running-bond bricks: per-brick colour from cell noise, mortar from the distance to the brick edges, grime from 5 octaves of fractal noise, mortar relief as a normal map.')
uv = g.texcoord('vector2')
s = g.multiply('vector2', in1=uv, in2=V2(4.0, 8.0))
sx = g.extract('float', in_=s, index=I(0)); sy = g.extract('float', in_=s, index=I(1))
row = g.floor('float', in_=sy)
shift = g.multiply('float', in1=g.modulo('float', in1=row, in2=F(2.0)), in2=F(0.5))
bx = g.add('float', in1=sx, in2=shift)
col = g.floor('float', in_=bx)
fx = g.subtract('float', in1=bx, in2=col); fy = g.subtract('float', in1=sy, in2=row)
ex = g.min('float', in1=fx, in2=g.subtract('float', in1=F(1.0), in2=fx))
ey = g.min('float', in1=fy, in2=g.subtract('float', in1=F(1.0), in2=fy))
edge = g.min('float', in1=g.multiply('float', in1=ex, in2=F(0.5)), in2=ey)
brick = g.smoothstep('float', in_=edge, low=F(0.03), high=F(0.06))
id2 = g.combine2('vector2', in1=col, in2=row)
cn = g.cellnoise2d('float', texcoord=id2)
tint = g.mix('color3', fg=C3(0.55, 0.22, 0.12), bg=C3(0.35, 0.12, 0.07), mix=cn)
pos = g.position('vector3')
grime = fbm(g, pos, 5, 6.0, 0.5)
gr = g.clamp('float', in_=g.add('float', in1=grime, in2=F(0.5)), low=F(0.0), high=F(1.0))
dirty = g.multiply('color3', in1=tint, in2=g.mix('float', fg=F(1.0), bg=F(0.6), mix=gr))
mortar = g.mix('color3', fg=C3(0.5, 0.48, 0.45), bg=C3(0.62, 0.6, 0.56), mix=gr)
base = g.mix('color3', fg=dirty, bg=mortar, mix=brick)
rough = g.mix('float', fg=F(0.8), bg=F(0.95), mix=brick)
height = g.add('float', in1=g.multiply('float', in1=brick, in2=F(0.02)), in2=g.multiply('float', in1=grime, in2=F(0.004)))
g.out('base_color', base); g.out('roughness', rough); g.out('metallic', g.constant('float', value=F(0.0)))
g.out('normal', hnormal(g, height, 1.0))
g.write()

# 2 marble ---------------------------------------------------------------
g = G('marble', 'Veined marble: a sine of position plus 7 octaves of turbulence, veins from a sharpened ramp, hue varied by low-frequency noise.')
pos = g.position('vector3')
turb = fbm(g, pos, 7, 3.0, 1.0)
x = g.extract('float', in_=pos, index=I(0)); z = g.extract('float', in_=pos, index=I(2))
t = g.add('float', in1=g.add('float', in1=g.multiply('float', in1=x, in2=F(4.0)), in2=g.multiply('float', in1=z, in2=F(1.5))), in2=g.multiply('float', in1=turb, in2=F(6.0)))
sv = g.sin('float', in_=t)
vein = g.power('float', in1=g.absval('float', in_=sv), in2=F(0.25))
vein2 = g.smoothstep('float', in_=vein, low=F(0.2), high=F(0.9))
low = g.noise3d('float', position=g.multiply('vector3', in1=pos, in2=F(0.7)), amplitude=F(0.5), pivot=F(0.5))
white = g.hsvadjust('color3', in_=C3(0.92, 0.9, 0.86), amount=g.combine3('vector3', in1=g.multiply('float', in1=low, in2=F(0.05)), in2=F(1.0), in3=F(1.0)))
base = g.mix('color3', fg=white, bg=C3(0.18, 0.2, 0.22), mix=vein2)
rough = g.mix('float', fg=F(0.08), bg=F(0.25), mix=vein2)
g.out('base_color', base); g.out('roughness', rough)
g.out('metallic', g.constant('float', value=F(0.0)))
g.write()

# 3 wood ---------------------------------------------------------------
g = G('wood', 'Growth rings around the y axis disturbed by 4 octaves of noise, fine grain from stretched 3D noise, late/early wood colours.')
pos = g.position('vector3')
x = g.extract('float', in_=pos, index=I(0)); z = g.extract('float', in_=pos, index=I(2)); y = g.extract('float', in_=pos, index=I(1))
r = g.magnitude('float', in_=g.combine2('vector2', in1=g.add('float', in1=x, in2=F(0.37)), in2=g.add('float', in1=z, in2=F(0.11))))
wob = fbm(g, pos, 4, 1.5, 0.6)
rings = g.fract('float', in_=g.multiply('float', in1=g.add('float', in1=r, in2=g.multiply('float', in1=wob, in2=F(0.08))), in2=F(12.0)))
ring = g.smoothstep('float', in_=rings, low=F(0.55), high=F(0.95))
grainp = g.multiply('vector3', in1=pos, in2=V3(60.0, 4.0, 60.0))
grain = g.noise3d('float', position=grainp, amplitude=F(0.5), pivot=F(0.5))
m = g.clamp('float', in_=g.add('float', in1=ring, in2=g.multiply('float', in1=grain, in2=F(0.3))), low=F(0.0), high=F(1.0))
base = g.mix('color3', fg=C3(0.28, 0.14, 0.06), bg=C3(0.62, 0.4, 0.22), mix=m)
g.out('base_color', base); g.out('roughness', g.mix('float', fg=F(0.55), bg=F(0.4), mix=m))
g.out('metallic', g.constant('float', value=F(0.0)))
g.out('normal', hnormal(g, g.multiply('float', in1=grain, in2=F(0.002)), 1.0))
g.write()

# 4 rust ---------------------------------------------------------------
g = G('rust', 'Painted steel rusting through: a 6-octave rust mask thresholded by smoothstep, pitting from 3D Worley noise, rust hue varied by hsvadjust; metallic where the steel shows.')
pos = g.position('vector3')
mask = fbm(g, pos, 6, 2.5, 1.0)
rm = g.smoothstep('float', in_=mask, low=F(-0.1), high=F(0.25))
pits = g.worleynoise3d('float', position=g.multiply('vector3', in1=pos, in2=F(14.0)), jitter=F(1.0))
pit = g.smoothstep('float', in_=pits, low=F(0.05), high=F(0.4))
detail = fbm(g, pos, 4, 20.0, 0.5)
hue = g.combine3('vector3', in1=g.multiply('float', in1=detail, in2=F(0.04)), in2=F(1.0), in3=g.add('float', in1=F(0.85), in2=g.multiply('float', in1=pit, in2=F(0.15))))
rustc = g.hsvadjust('color3', in_=C3(0.42, 0.16, 0.05), amount=hue)
steel = g.mix('color3', fg=C3(0.56, 0.57, 0.58), bg=C3(0.12, 0.3, 0.18), mix=g.smoothstep('float', in_=mask, low=F(-0.3), high=F(-0.2)))
base = g.mix('color3', fg=rustc, bg=steel, mix=rm)
metal = g.multiply('float', in1=g.subtract('float', in1=F(1.0), in2=rm), in2=g.smoothstep('float', in_=mask, low=F(-0.3), high=F(-0.2)))
g.out('base_color', base); g.out('metallic', metal)
g.out('roughness', g.mix('float', fg=F(0.9), bg=F(0.35), mix=rm))
g.write()

# 5 fabric ---------------------------------------------------------------
g = G('fabric', 'Plain-weave cloth: warp and weft threads from sines of uv, alternating over/under from a checkerboard, fibre fuzz from 2D noise.')
uv = g.texcoord('vector2')
s = g.multiply('vector2', in1=uv, in2=V2(60.0, 60.0))
sx = g.extract('float', in_=s, index=I(0)); sy = g.extract('float', in_=s, index=I(1))
wx = g.absval('float', in_=g.sin('float', in_=g.multiply('float', in1=sx, in2=F(3.14159265))))
wy = g.absval('float', in_=g.sin('float', in_=g.multiply('float', in1=sy, in2=F(3.14159265))))
chk = g.checkerboard('color3', texcoord=uv, uvtiling=V2(60.0, 60.0), color1=C3(1, 1, 1), color2=C3(0, 0, 0))
over = g.extract('float', in_=chk, index=I(0))
thread = g.mix('float', fg=wx, bg=wy, mix=over)
fuzz = g.noise2d('float', texcoord=g.multiply('vector2', in1=uv, in2=F(400.0)), amplitude=F(0.15), pivot=F(0.0))
shade = g.clamp('float', in_=g.add('float', in1=g.multiply('float', in1=thread, in2=F(0.7)), in2=g.add('float', in1=fuzz, in2=F(0.3))), low=F(0.0), high=F(1.0))
base = g.multiply('color3', in1=C3(0.2, 0.27, 0.55), in2=shade)
g.out('base_color', base); g.out('roughness', g.constant('float', value=F(0.95)))
g.out('metallic', g.constant('float', value=F(0.0)))
g.out('normal', hnormal(g, g.multiply('float', in1=thread, in2=F(0.0015)), 1.0))
g.write()

# 6 concrete ---------------------------------------------------------------
g = G('concrete', 'Cast concrete: 6 octaves of blotches, aggregate from 2D Worley cells, air pores from thresholded 3D Worley noise.')
pos = g.position('vector3'); uv = g.texcoord('vector2')
bl = fbm(g, pos, 6, 1.8, 0.5)
agg = g.worleynoise2d('float', texcoord=g.multiply('vector2', in1=uv, in2=F(40.0)), jitter=F(0.9), style=I(1))
pores = g.worleynoise3d('float', position=g.multiply('vector3', in1=pos, in2=F(30.0)), jitter=F(1.0))
pore = g.smoothstep('float', in_=pores, low=F(0.04), high=F(0.12))
grey = g.add('float', in1=F(0.5), in2=g.add('float', in1=g.multiply('float', in1=bl, in2=F(0.25)), in2=g.multiply('float', in1=agg, in2=F(0.08))))
c = g.multiply('float', in1=grey, in2=g.mix('float', fg=F(1.0), bg=F(0.45), mix=pore))
base = g.multiply('color3', in1=C3(0.95, 0.93, 0.9), in2=c)
g.out('base_color', base); g.out('roughness', g.mix('float', fg=F(0.85), bg=F(1.0), mix=pore))
g.out('metallic', g.constant('float', value=F(0.0)))
g.out('normal', hnormal(g, g.multiply('float', in1=pore, in2=F(0.003)), 1.0))
g.write()

# 7 tiles ---------------------------------------------------------------
g = G('tiles', 'Glazed floor tiles: two colours on a checkerboard, grout lines from the fractional uv, per-tile hue jitter from cell noise, glaze roughness from noise.')
uv = g.texcoord('vector2')
p = g.place2d('vector2', texcoord=uv, scale=V2(0.125, 0.125), rotate=F(0.0))
fr = g.fract('vector2', in_=p)
fl = g.floor('vector2', in_=p)
fx = g.extract('float', in_=fr, index=I(0)); fy = g.extract('float', in_=fr, index=I(1))
dx = g.min('float', in1=fx, in2=g.subtract('float', in1=F(1.0), in2=fx))
dy = g.min('float', in1=fy, in2=g.subtract('float', in1=F(1.0), in2=fy))
tile = g.smoothstep('float', in_=g.min('float', in1=dx, in2=dy), low=F(0.02), high=F(0.035))
chk = g.checkerboard('color3', texcoord=uv, uvtiling=V2(8.0, 8.0), color1=C3(0.85, 0.83, 0.78), color2=C3(0.1, 0.22, 0.35))
j = g.cellnoise2d('float', texcoord=fl)
tint = g.hsvadjust('color3', in_=chk, amount=g.combine3('vector3', in1=g.multiply('float', in1=g.subtract('float', in1=j, in2=F(0.5)), in2=F(0.04)), in2=F(1.0), in3=g.add('float', in1=F(0.9), in2=g.multiply('float', in1=j, in2=F(0.2)))))
base = g.mix('color3', fg=tint, bg=C3(0.45, 0.43, 0.4), mix=tile)
gl = g.noise2d('float', texcoord=g.multiply('vector2', in1=uv, in2=F(25.0)), amplitude=F(0.05), pivot=F(0.1))
g.out('base_color', base); g.out('roughness', g.mix('float', fg=gl, bg=F(0.9), mix=tile))
g.out('metallic', g.constant('float', value=F(0.0)))
g.out('normal', hnormal(g, g.multiply('float', in1=tile, in2=F(0.01)), 1.0))
g.write()

# 8 cardboard ---------------------------------------------------------------
g = G('cardboard', 'Corrugated cardboard: flutes from a sine of v, paper fibres from stretched 2D noise and 4 octaves of blotches, a printed ramp.')
uv = g.texcoord('vector2'); pos = g.position('vector3')
v = g.extract('float', in_=uv, index=I(1))
flute = g.multiply('float', in1=g.add('float', in1=g.sin('float', in_=g.multiply('float', in1=v, in2=F(150.0))), in2=F(1.0)), in2=F(0.5))
fib = g.noise2d('float', texcoord=g.multiply('vector2', in1=uv, in2=V2(300.0, 20.0)), amplitude=F(0.5), pivot=F(0.5))
bl = fbm(g, pos, 4, 3.0, 0.5)
ramp = g.ramplr('color3', valuel=C3(0.55, 0.4, 0.25), valuer=C3(0.6, 0.46, 0.3), texcoord=uv)
shade = g.add('float', in1=F(0.8), in2=g.add('float', in1=g.multiply('float', in1=fib, in2=F(0.15)), in2=g.multiply('float', in1=bl, in2=F(0.1))))
base = g.multiply('color3', in1=ramp, in2=g.multiply('float', in1=shade, in2=g.add('float', in1=F(0.9), in2=g.multiply('float', in1=flute, in2=F(0.1)))))
g.out('base_color', base); g.out('roughness', g.constant('float', value=F(0.9)))
g.out('metallic', g.constant('float', value=F(0.0)))
g.out('normal', hnormal(g, g.multiply('float', in1=flute, in2=F(0.002)), 1.0))
g.write()

# 9 granite ---------------------------------------------------------------
g = G('granite', 'Polished granite: mineral grains from 3D Worley cells (solid and distance styles), speckle from cell noise, 5 octaves of cloudiness.')
pos = g.position('vector3')
grains = g.worleynoise3d('vector2', position=g.multiply('vector3', in1=pos, in2=F(25.0)), jitter=F(1.0), style=I(0))
cellv = g.worleynoise3d('float', position=g.multiply('vector3', in1=pos, in2=F(25.0)), jitter=F(1.0), style=I(1))
f1 = g.extract('float', in_=grains, index=I(0)); f2 = g.extract('float', in_=grains, index=I(1))
border = g.smoothstep('float', in_=g.subtract('float', in1=f2, in2=f1), low=F(0.0), high=F(0.08))
spk = g.cellnoise3d('float', position=g.multiply('vector3', in1=pos, in2=F(120.0)))
cl = fbm(g, pos, 5, 2.0, 0.5)
mineral = g.ifgreater('color3', value1=cellv, value2=F(0.7), in1=C3(0.08, 0.07, 0.07), in2=g.ifgreater('color3', value1=cellv, value2=F(0.35), in1=C3(0.7, 0.62, 0.58), in2=C3(0.45, 0.42, 0.42)))
dark = g.multiply('color3', in1=mineral, in2=g.add('float', in1=F(0.85), in2=g.multiply('float', in1=cl, in2=F(0.3))))
sp = g.ifgreater('float', value1=spk, value2=F(0.97), in1=F(1.6), in2=F(1.0))
base = g.multiply('color3', in1=g.multiply('color3', in1=dark, in2=border), in2=sp)
g.out('base_color', base); g.out('roughness', g.constant('float', value=F(0.12)))
g.out('metallic', g.constant('float', value=F(0.0)))
g.write()

# 10 leather ---------------------------------------------------------------
g = G('leather', 'Grained leather: cells from 2D Worley F2-F1 creases, 3 octaves of wear, colour from a top-to-bottom ramp.')
uv = g.texcoord('vector2'); pos = g.position('vector3')
w = g.worleynoise2d('vector2', texcoord=g.multiply('vector2', in1=uv, in2=F(80.0)), jitter=F(0.8))
f1 = g.extract('float', in_=w, index=I(0)); f2 = g.extract('float', in_=w, index=I(1))
crease = g.smoothstep('float', in_=g.subtract('float', in1=f2, in2=f1), low=F(0.0), high=F(0.25))
wear = fbm(g, pos, 3, 4.0, 0.5)
ramp = g.ramptb('color3', valuet=C3(0.25, 0.12, 0.06), valueb=C3(0.18, 0.08, 0.04), texcoord=uv)
c = g.multiply('color3', in1=ramp, in2=g.add('float', in1=g.multiply('float', in1=crease, in2=F(0.4)), in2=g.add('float', in1=F(0.6), in2=g.multiply('float', in1=wear, in2=F(0.3)))))
g.out('base_color', c); g.out('roughness', g.mix('float', fg=F(0.45), bg=F(0.7), mix=crease))
g.out('metallic', g.constant('float', value=F(0.0)))
g.out('normal', hnormal(g, g.multiply('float', in1=crease, in2=F(0.002)), 1.0))
g.write()

# 11 lava ---------------------------------------------------------------
g = G('lava', 'Cooling lava: glowing cracks from 3D Worley F2-F1, crust from 6 octaves of noise, emission falling off from the cracks.')
pos = g.position('vector3')
w = g.worleynoise3d('vector2', position=g.multiply('vector3', in1=pos, in2=F(4.0)), jitter=F(1.0))
f1 = g.extract('float', in_=w, index=I(0)); f2 = g.extract('float', in_=w, index=I(1))
crack = g.subtract('float', in1=F(1.0), in2=g.smoothstep('float', in_=g.subtract('float', in1=f2, in2=f1), low=F(0.0), high=F(0.12)))
crust = fbm(g, pos, 6, 3.0, 0.5)
heat = g.clamp('float', in_=g.add('float', in1=crack, in2=g.multiply('float', in1=crust, in2=F(0.3))), low=F(0.0), high=F(1.0))
em = g.multiply('color3', in1=C3(6.0, 1.6, 0.2), in2=g.power('float', in1=heat, in2=F(3.0)))
base = g.mix('color3', fg=C3(0.3, 0.08, 0.02), bg=C3(0.05, 0.045, 0.04), mix=heat)
g.out('base_color', base); g.out('emission', em)
g.out('roughness', g.mix('float', fg=F(0.6), bg=F(0.95), mix=heat))
g.out('metallic', g.constant('float', value=F(0.0)))
g.write()

# 12 terrazzo ---------------------------------------------------------------
g = G('terrazzo', 'Terrazzo: stone chips from 2D Worley cells (solid style gives each chip its colour), chip edges from F1, cement from noise; hue per chip by hsvadjust.')
uv = g.texcoord('vector2')
p = g.multiply('vector2', in1=uv, in2=F(30.0))
cell = g.worleynoise2d('float', texcoord=p, jitter=F(0.9), style=I(1))
d = g.worleynoise2d('float', texcoord=p, jitter=F(0.9), style=I(0))
chip = g.subtract('float', in1=F(1.0), in2=g.smoothstep('float', in_=d, low=F(0.3), high=F(0.36)))
hue = g.combine3('vector3', in1=cell, in2=F(0.6), in3=g.add('float', in1=F(0.6), in2=g.multiply('float', in1=cell, in2=F(0.4))))
chipc = g.hsvadjust('color3', in_=C3(0.8, 0.3, 0.3), amount=hue)
cem = g.noise2d('float', texcoord=g.multiply('vector2', in1=uv, in2=F(90.0)), amplitude=F(0.05), pivot=F(0.75))
base = g.mix('color3', fg=chipc, bg=g.convert('color3', in_=cem), mix=chip)
lum = g.luminance('color3', in_=base)
g.out('base_color', base); g.out('roughness', g.mix('float', fg=F(0.15), bg=F(0.3), mix=g.extract('float', in_=lum, index=I(0))))
g.out('metallic', g.constant('float', value=F(0.0)))
g.write()
