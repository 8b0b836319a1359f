"""Task representation: hierarchical first-order AND/OR graphs (paper 000, section IV)."""
