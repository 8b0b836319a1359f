"""Knowledge base: typed objects, poses, facts, closed world, consistency (paper 000, V-VI).

See :class:`KnowledgeBase`.
"""

from flexhrc.knowledge.base import Inconsistency, KnowledgeBase, ObjectRecord

__all__ = ["Inconsistency", "KnowledgeBase", "ObjectRecord"]
