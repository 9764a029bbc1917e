"""Small SVG plots, written by hand (no plotting library): a time axis in dates, a value
axis with round ticks, points with error bars, bands, lines, markers. The look and the tick
rule are the C++ reports' (libcalib/src/io/svg_plot.cc): sans-serif 12 px, a dark frame,
grey grid lines at the value ticks, tick marks below, the title above the frame, the value
axis's label turned along it; only the time axis differs (dates: month starts or weeks)."""
import datetime
import html
import math


def ticks(lo, hi):
    """The report plots' tick rule, the same as the C++ reports' (libcalib/src/io/svg_plot.h,
    SvgTicks; fleet_unit compares the two): about five round values over [lo, hi], the step
    2, 5 or 10 times a power of ten, from the first multiple of the step at or above lo; labels
    with 4 significant digits, more where the step needs them. [(value, label)]. The same
    floating-point operations in the same order as the C++, so the same values to the bit."""
    span = hi - lo
    if not span > 0:
        return [(lo, f"{lo:.4g}")]
    if math.isinf(span):
        return []
    raw = span / 5
    mag = math.pow(10.0, math.floor(math.log10(raw)))
    step = 2 * mag if raw / mag < 2 else 5 * mag if raw / mag < 5 else 10 * mag
    out = []
    v = math.ceil(lo / step) * step
    while v <= hi + 1e-9 * span:
        value = 0.0 if abs(v) < 1e-12 * step else v
        digits = 4
        if value != 0:  # down to the step's digit: 116.25 and 116.3, not 116.2 twice
            digits = max(digits, math.floor(math.log10(abs(value))) - math.floor(math.log10(step)) + 1)
        out.append((value, f"{value:.{digits}g}"))
        v += step
    return out


class Plot:
    """A plot of value against time (days since 1970, floats)."""

    def __init__(self, width=640, height=200, title="", ylabel="", xlo=None, xhi=None, ylo=None, yhi=None):
        self.w, self.h = width, height
        self.ml, self.mr, self.mt, self.mb = 80, 12, 22, 26
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
               f'font-family="sans-serif" font-size="12">',
               '<rect width="100%" height="100%" fill="white"/>',
               f'<clipPath id="c"><rect x="{ml}" y="{mt}" width="{w - ml - mr}" height="{h - mt - mb}"/></clipPath>']
        if self.title:
            out.append(f'<text x="{ml}" y="{mt - 6}" font-size="13">{html.escape(self.title)}</text>')
        out.append(f'<rect x="{ml}" y="{mt}" width="{w - ml - mr}" height="{h - mt - mb}" fill="none" stroke="#444"/>')
        for x, label in date_ticks(self.xlo, self.xhi) if xdates else ticks(self.xlo, self.xhi):
            px = self.X(x)
            out.append(f'<line x1="{px:.1f}" x2="{px:.1f}" y1="{h - mb}" y2="{h - mb + 4}" stroke="#444"/>'
                       f'<text x="{px:.1f}" y="{h - mb + 16}" text-anchor="middle">{label}</text>')
        for v, label in ticks(self.ylo, self.yhi) if yticks else []:
            py = self.Y(v)
            out.append(f'<line x1="{ml - 4}" x2="{w - mr}" y1="{py:.1f}" y2="{py:.1f}" stroke="#ddd"/>'
                       f'<text x="{ml - 6}" y="{py + 4:.1f}" text-anchor="end">{label}</text>')
        if self.ylabel:
            out.append(f'<text transform="translate(16,{(mt + h - mb) / 2:.1f}) rotate(-90)" '
                       f'text-anchor="middle">{html.escape(self.ylabel)}</text>')
        out.append('<g clip-path="url(#c)">' + "".join(self.items) + "</g>")
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
