"""The fleet report's plots: matplotlib figures (Debian python3-matplotlib) in the C++ reports'
look (libcalib/src/io/svg_plot.cc): sans-serif 12 px, a dark frame, grey grid lines at the value
ticks, the title above the frame on the left, the legend beside the frame on the right, the unit
along each axis. The value axis takes the reports' tick rule (`ticks`, the C++ SvgTicks'); the
time axis is the fleet's own, in dates (`date_ticks`). The SVG keeps its text as text and is
the same bytes for the same figure."""
import datetime
import html
import io
import math

WIDTH = 900  # px, the C++ reports' plots' width
# The frame's margins in px, the C++ reports' (svg_plot.cc): every plot of a page lines up.
LEFT, RIGHT, TOP, BOTTOM = 80, 170, 30, 45


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


def date_ticks(lo, hi):
    """Ticks at month starts, or weeks for short spans: [(day, label)] (days since 1970)."""
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


def figure(height, width=WIDTH, bottom=BOTTOM, legend=True):
    """A figure of width x height px with one axes in the reports' frame: fixed margins, so that
    the plots of a page share their time axis's pixels; the right margin holds the legend."""
    import matplotlib
    from matplotlib.figure import Figure
    matplotlib.rcParams["svg.hashsalt"] = "agvcal"  # fixed ids: the same bytes for the same figure
    matplotlib.rcParams["font.family"] = "sans-serif"
    matplotlib.rcParams["svg.fonttype"] = "none"  # text as text: names a page can search
    fig = Figure(figsize=(width / 72, height / 72), dpi=72)  # 1 pt = 1 px: font sizes as the reports' px
    fig.subplots_adjust(left=LEFT / width, right=1 - (RIGHT if legend else 12) / width,
                        top=1 - TOP / height, bottom=bottom / height)
    ax = fig.add_subplot()
    for side in ax.spines.values():
        side.set_color("#444")
    ax.tick_params(colors="#222", labelsize=12)
    return fig, ax


def title(ax, text):
    ax.set_title(text, loc="left", fontsize=13)


def value_axis(ax, lo, hi, label):
    """The value axis over [lo, hi] with the reports' ticks and grid, its label the unit."""
    marks = ticks(lo, hi)
    ax.set_ylim(lo, hi)
    ax.set_yticks([v for v, _ in marks])
    ax.set_yticklabels([t for _, t in marks])
    ax.yaxis.grid(True, color="#ddd")
    ax.set_axisbelow(True)
    ax.set_ylabel(label, fontsize=12)


def padded(values, pad=0.08):
    """[lo, hi] around the finite values with a margin (a flat series gets a small span)."""
    vs = [v for v in values if v is not None and math.isfinite(v)]
    if not vs:
        return 0.0, 1.0
    lo, hi = min(vs), max(vs)
    if hi - lo <= 1e-15 * max(1.0, abs(hi)):
        lo, hi = lo - max(abs(lo) * 1e-3, 1e-9), hi + max(abs(hi) * 1e-3, 1e-9)
    return lo - pad * (hi - lo), hi + pad * (hi - lo)


def date_axis(ax, lo, hi):
    """The time axis over [lo, hi] (days since 1970) with date ticks, its label the unit: the
    date in UTC, and the year where the labels leave it out."""
    marks = date_ticks(lo, hi)
    ax.set_xlim(lo, hi)
    ax.set_xticks([x for x, _ in marks])
    ax.set_xticklabels([t for _, t in marks])
    label = "date (UTC)"
    years = sorted({(datetime.date(1970, 1, 1) + datetime.timedelta(days=math.floor(x))).year for x in (lo, hi)})
    if marks and len(marks[0][1]) == 5:  # month-day labels
        label = f"date in {'–'.join(str(y) for y in years)} (UTC, month-day)"
    ax.set_xlabel(label, fontsize=12)


def legend(ax, handles):
    """The legend beside the frame, on the right (as the C++ reports'), naming only what is drawn."""
    if handles:
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0,
                  frameon=False, fontsize=10, handlelength=1.6)


def to_svg(fig, titles=None):
    """The figure as SVG text, the same bytes for the same figure (no date, fixed ids). TITLES
    maps an artist's gid to a tooltip, written as the <title> of its group."""
    out = io.StringIO()
    fig.savefig(out, format="svg", metadata={"Date": None})
    text = out.getvalue()
    for gid, tip in (titles or {}).items():
        text = text.replace(f'<g id="{gid}">', f'<g id="{gid}">\n<title>{html.escape(tip)}</title>', 1)
    return text
