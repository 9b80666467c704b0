"""What the object in the grip is made of, as far as the FingerVision contact depends on it: how
well it grips the silicone skin (Coulomb friction, plus adhesion for clean smooth surfaces), how
large a patch it presses into the gel (its stiffness against the gel's: a soft object conforms and
spreads the load, so the markers move less per newton), and how stiff it is end-on (the press
scene pushes it on a scale).

The paper stresses that the learned force mapping is object-dependent ("the FingerVision gets
stuck on glass"): clean glass adheres to silicone, so it barely slips and the skin shears further
before letting go. No measured figure exists for this gel against these materials; the numbers
are typical values of the materials with ranges, so a scene names an object (`object: glass`) and
a randomised scene may draw within the ranges.

Marker gain. A Hertz contact's radius grows as (F R / E*)^(1/3) with 1/E* = (1 - nu_g^2)/E_g +
(1 - nu_o^2)/E_o; the gel's shear and squash seen by the markers, per newton, fall as the patch
grows (the load spreads over more gel). `marker_gain` is that per-newton motion relative to a
rigid object: (E*_object / E*_rigid)^(1/3): 1.0 for glass, wood and steel, 0.91 for rubber, 0.33 for
foam (the silicone gel itself: E about 1 MPa, nu 0.5).
"""

from __future__ import annotations

from dataclasses import dataclass

GEL_MODULUS = 1.0e6  # Pa, a soft silicone skin (Shore 00-30 .. A-10 silicones: 0.1-1 MPa; the stiff end)
GEL_POISSON = 0.5  # incompressible rubber


@dataclass(frozen=True)
class GrippedObject:
    """One material's contact with the skin. Friction is against silicone (dry); adhesion is the
    tangential load (N, both pads together) the contact carries with no squeeze at all."""

    name: str
    friction: float  # Coulomb coefficient against the silicone skin
    adhesion: float  # N of tangential load carried beyond friction (clean smooth surfaces stick)
    modulus: float  # Pa, Young's modulus of the object's surface
    poisson: float
    stiffness: float  # N/m end-on (the press scene's stick tip on the scale, in series with the scale)
    about: str  # where the numbers come from, and their ranges

    def effective_modulus(self) -> float:
        """E* of this object against the gel (Pa)."""
        return 1.0 / ((1.0 - GEL_POISSON**2) / GEL_MODULUS + (1.0 - self.poisson**2) / self.modulus)

    @property
    def marker_gain(self) -> float:
        """Marker motion per newton relative to a rigid object (<= 1)."""
        rigid = GEL_MODULUS / (1.0 - GEL_POISSON**2)
        return (self.effective_modulus() / rigid) ** (1.0 / 3.0)


OBJECTS: dict[str, GrippedObject] = {o.name: o for o in (
    GrippedObject("wood", 0.8, 0.0, 1.0e10, 0.35, 4000.0,
                  "planed softwood: rubber on dry wood 0.6-0.9 (0.8 = the cells' former world friction); "
                  "E 8-12 GPa along the grain; end-on 4000 N/m = the press scene's former scale contact"),
    GrippedObject("glass", 1.6, 3.0, 7.0e10, 0.22, 5000.0,
                  "clean glass: silicone rubber on glass 1-3 with adhesion ('the FingerVision gets stuck "
                  "on glass'); adhesion 0-6 N for a 2 cm contact; E 70 GPa"),
    GrippedObject("rubber", 1.0, 0.5, 3.0e6, 0.49, 2500.0,
                  "natural rubber: rubber on rubber 0.8-1.2, slight tack 0-1 N; E 1-10 MPa"),
    GrippedObject("foam", 0.6, 0.0, 5.0e4, 0.1, 600.0,
                  "polyurethane foam: 0.4-0.8 against rubber; E 0.02-0.2 MPa; soft end-on (200-1500 N/m)"),
    GrippedObject("steel", 0.5, 0.0, 2.0e11, 0.3, 6000.0,
                  "machined steel: rubber on dry steel 0.4-0.7 (oily: 0.2-0.4); E 200 GPa"),
)}


def gripped_object(name: object) -> GrippedObject | None:
    """The object a scene arg names (None: the scene's own neutral contact, the cell's world
    friction); ValueError naming the known objects otherwise."""
    if name is None:
        return None
    if name not in OBJECTS:
        raise ValueError(f"unknown object {name!r}; known: {', '.join(sorted(OBJECTS))}")
    return OBJECTS[str(name)]
