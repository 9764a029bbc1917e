"""Small SVG plots, written by hand (no plotting library): a time axis in dates, a value
axis with round ticks, points with error bars, bands, lines, markers."""
import datetime
import html
import math


def nice_ticks(lo, hi, n=5):
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return [lo]
    raw = (hi - lo) / n
    mag = 10 ** math.floor(math.log10(raw))
    step = min((m * mag for m in (1, 2, 2.5, 5, 10) if m * mag >= raw), default=10 * mag)
    start = math.ceil(lo / step) * step
    out = []
    v = start
    while v <= hi + 1e-12 * abs(hi) + 1e-300:
        out.append(round(v, 12))
        v += step
    return out


def fmt_tick(v, step):
    if step == 0 or not math.isfinite(step):
        return f"{v:g}"
    d = next((k for k in range(12) if abs(round(step, k) - step) <= 1e-9 * abs(step)), 12)
    return f"{v:.{d}f}"


class Plot:
    """A plot of value against time (days since 1970, floats)."""

    def __init__(self, width=640, height=200, title="", ylabel="", xlo=None, xhi=None, ylo=None, yhi=None):
        self.w, self.h = width, height
        self.ml, self.mr, self.mt, self.mb = 64, 12, 22, 26
        self.title, self.ylabel = title, ylabel
        self.xlo, self.xhi, self.ylo, self.yhi = xlo, xhi, ylo, yhi
        self.items = []

    # -- scales -------------------------------------------------------------------------
    def fit(self, xs, ys, pad=0.08):
        xs = [x for x in xs if x is not None and math.isfinite(x)]
        ys = [y for y in ys if y is not None and math.isfinite(y)]
        if xs:
            lo, hi = min(xs), max(xs)
            if hi - lo < 1:
                lo, hi = lo - 0.5, hi + 0.5
            span = hi - lo
            self.xlo = lo - pad * span / 2 if self.xlo is None else self.xlo
            self.xhi = hi + pad * span / 2 if self.xhi is None else self.xhi
        if ys:
            lo, hi = min(ys), max(ys)
            if hi - lo <= 1e-15 * max(1.0, abs(hi)):
                lo, hi = lo - max(abs(lo) * 1e-3, 1e-9), hi + max(abs(hi) * 1e-3, 1e-9)
            span = hi - lo
            self.ylo = lo - pad * span if self.ylo is None else self.ylo
            self.yhi = hi + pad * span if self.yhi is None else self.yhi

    def X(self, x):
        return self.ml + (x - self.xlo) / (self.xhi - self.xlo) * (self.w - self.ml - self.mr)

    def Y(self, y):
        return self.mt + (self.yhi - y) / (self.yhi - self.ylo) * (self.h - self.mt - self.mb)

    # -- items --------------------------------------------------------------------------
    def band(self, xs, lo, hi, color="#9ecae1", opacity=0.35):
        pts = [(self.X(x), self.Y(y)) for x, y in zip(xs, hi)] + \
              [(self.X(x), self.Y(y)) for x, y in reversed(list(zip(xs, lo)))]
        self.items.append(f'<polygon points="{_pts(pts)}" fill="{color}" fill-opacity="{opacity}" stroke="none"/>')

    def line(self, xs, ys, color="#08519c", width=1.5, dash=None):
        pts = [(self.X(x), self.Y(y)) for x, y in zip(xs, ys) if y is not None and math.isfinite(y)]
        d = f' stroke-dasharray="{dash}"' if dash else ""
        self.items.append(f'<polyline points="{_pts(pts)}" fill="none" stroke="{color}" stroke-width="{width}"{d}/>')

    def points(self, xs, ys, errs=None, color="#252525", r=2.6, titles=None):
        for i, (x, y) in enumerate(zip(xs, ys)):
            if y is None or not math.isfinite(y):
                continue
            cx, cy = self.X(x), self.Y(y)
            if errs and errs[i] and math.isfinite(errs[i]):
                y0, y1 = self.Y(y - errs[i]), self.Y(y + errs[i])
                self.items.append(f'<line x1="{cx:.1f}" y1="{y0:.1f}" x2="{cx:.1f}" y2="{y1:.1f}" stroke="{color}" stroke-width="1"/>')
            t = f"<title>{html.escape(titles[i])}</title>" if titles else ""
            self.items.append(f'<circle cx="{cx:.1f}" cy="{cy:.1f}" r="{r}" fill="{color}">{t}</circle>')

    def vline(self, x, color="#d62728", label="", dash="4 3"):
        px = self.X(x)
        self.items.append(f'<line x1="{px:.1f}" y1="{self.mt}" x2="{px:.1f}" y2="{self.h - self.mb}" '
                          f'stroke="{color}" stroke-width="1.2" stroke-dasharray="{dash}"/>')
        if label:
            anchor = "end" if px > self.w * 0.7 else "start"
            dx = -3 if anchor == "end" else 3
            self.items.append(f'<text x="{px + dx:.1f}" y="{self.mt + 10}" font-size="10" fill="{color}" '
                              f'text-anchor="{anchor}">{html.escape(label)}</text>')

    def hline(self, y, color="#888", dash="2 3"):
        py = self.Y(y)
        self.items.append(f'<line x1="{self.ml}" y1="{py:.1f}" x2="{self.w - self.mr}" y2="{py:.1f}" '
                          f'stroke="{color}" stroke-width="1" stroke-dasharray="{dash}"/>')

    def raw(self, s):
        self.items.append(s)

    # -- output -------------------------------------------------------------------------
    def render(self, xdates=True, yticks=True):
        if self.xlo is None:
            self.fit([0, 1], [0, 1])
        w, h, ml, mr, mt, mb = self.w, self.h, self.ml, self.mr, self.mt, self.mb
        out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" '
               f'font-family="DejaVu Sans, Arial, sans-serif">',
               f'<rect x="0" y="0" width="{w}" height="{h}" fill="white"/>',
               f'<clipPath id="c"><rect x="{ml}" y="{mt}" width="{w - ml - mr}" height="{h - mt - mb}"/></clipPath>']
        # axes and grid
        yt = nice_ticks(self.ylo, self.yhi, 4) if yticks else []
        step = yt[1] - yt[0] if len(yt) > 1 else 0
        for v in yt:
            py = self.Y(v)
            out.append(f'<line x1="{ml}" y1="{py:.1f}" x2="{w - mr}" y2="{py:.1f}" stroke="#eee"/>')
            out.append(f'<text x="{ml - 4}" y="{py + 3.5:.1f}" font-size="10" text-anchor="end">{fmt_tick(v, step)}</text>')
        for x, label in (date_ticks(self.xlo, self.xhi) if xdates else
                         [(v, f"{v:g}") for v in nice_ticks(self.xlo, self.xhi, 6)]):
            px = self.X(x)
            out.append(f'<line x1="{px:.1f}" y1="{mt}" x2="{px:.1f}" y2="{h - mb}" stroke="#f2f2f2"/>')
            out.append(f'<text x="{px:.1f}" y="{h - mb + 13}" font-size="10" text-anchor="middle">{label}</text>')
        out.append(f'<rect x="{ml}" y="{mt}" width="{w - ml - mr}" height="{h - mt - mb}" fill="none" stroke="#999"/>')
        out.append(f'<g clip-path="url(#c)">' + "".join(self.items) + "</g>")
        if self.title:
            out.append(f'<text x="{ml}" y="14" font-size="12" font-weight="bold">{html.escape(self.title)}</text>')
        if self.ylabel:
            out.append(f'<text x="{w - mr}" y="14" font-size="10" text-anchor="end" fill="#555">{html.escape(self.ylabel)}</text>')
        out.append("</svg>")
        return "\n".join(out)


def date_ticks(lo, hi):
    """Ticks at month starts, or weeks for short spans: [(day, label)]."""
    d0 = datetime.date(1970, 1, 1)
    span = hi - lo
    out = []
    if span > 60:
        d = d0 + datetime.timedelta(days=math.floor(lo))
        d = datetime.date(d.year, d.month, 1)
        while True:
            x = (d - d0).days
            if x > hi:
                break
            if x >= lo:
                out.append((x, d.strftime("%Y-%m-%d")))
            d = datetime.date(d.year + (d.month == 12), d.month % 12 + 1, 1)
        if len(out) > 7:
            out = out[::2]
    else:
        step = 7 if span > 14 else 1
        if span > 35:
            step = 14
        x = math.ceil(lo)
        while (x - 4) % 7:  # Mondays (1970-01-05 was a Monday)
            x += 1
        if step == 1:
            x = math.ceil(lo)
        while x <= hi:
            out.append((x, (d0 + datetime.timedelta(days=x)).strftime("%m-%d")))
            x += step
    return out


def _pts(pts):
    return " ".join(f"{x:.1f},{y:.1f}" for x, y in pts)
