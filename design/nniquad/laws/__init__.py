"""The horizontal control laws: one module per law, one interface, one registry.

====================  =============================================  ========================================
module                law (``--controller``)                         gains
====================  =============================================  ========================================
:mod:`.nni`           ``nni``: the paper's integral resonant law      :class:`Gains` (kp, Gamma, delta)
:mod:`.sni2`          ``sni2``: second-order SNI controller           :class:`SNI2Gains` (kp, k, omega, zeta)
:mod:`.pd_filtered`   ``pd_filtered``: PD, dirty derivative           :class:`PDFilteredGains` (kp, kd, tau_f)
:mod:`.pd_velocity`   ``pd_velocity``: PD with the true velocity      :class:`PDGains` (kp, kd)
:mod:`.integral`      ``nni_i``, ``sni2_i``: integral action          the base law's gains and ki
====================  =============================================  ========================================

:mod:`.base` is the interface (:class:`ControlLaw`, :class:`NILaw` for the
paper's NI structure), :mod:`.registry` maps names to laws, :mod:`.classes`
says which theorem certifies a design (``paper``, ``cascade``).  Importing this
package registers every law above; a new law is one more module and one more
import line here (``docs/architecture.md``).
"""

from nniquad.laws import nni, pd_filtered, pd_velocity, sni2  # noqa: F401  (each registers its law)
from nniquad.laws import integral  # noqa: F401,I001  (registers nni_i, sni2_i: after the laws above, the registry's order)
from nniquad.laws.base import ControlLaw, GainBlock, NILaw, field_unit, positive_gain
from nniquad.laws.classes import DEFAULT_LAW_CLASS, LAW_CLASSES, SECTOR_RTOL, LawClass, law_class, within_sector_bound
from nniquad.laws.integral import NNIIntegralGains, SNI2IntegralGains, integral_variant
from nniquad.laws.nni import PAPER_GAINS, Gains, NNIGains
from nniquad.laws.pd_filtered import DEFAULT_TAU_F_S, PDFilteredGains
from nniquad.laws.pd_velocity import PDGains
from nniquad.laws.registry import LAWS, law_named, law_names, law_of, ni_law_names, register, to_gains
from nniquad.laws.sni2 import SNI2Gains

__all__ = ["ControlLaw", "NILaw", "GainBlock", "field_unit", "positive_gain", "LAWS", "law_named", "law_names",
           "law_of", "ni_law_names", "register", "to_gains", "Gains", "NNIGains", "PAPER_GAINS", "SNI2Gains",
           "PDFilteredGains", "PDGains", "DEFAULT_TAU_F_S", "LawClass", "LAW_CLASSES", "DEFAULT_LAW_CLASS",
           "law_class", "SECTOR_RTOL", "within_sector_bound", "integral_variant", "NNIIntegralGains",
           "SNI2IntegralGains"]
