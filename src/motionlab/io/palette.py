"""Colours shared by the matplotlib figures and the standalone HTML animations (no matplotlib import here:
writing a dataset or an HTML file must not pay for pyplot)."""

# Right side warm, left side cool, spine neutral: chains are (right leg, left leg, spine, right arm, left arm) for t2m.
CHAIN_COLORS = ("#d62728", "#1f77b4", "#2f2f2f", "#ff7f0e", "#17becf")
