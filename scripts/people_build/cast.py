"""The people the build makes: body (sex, age, build, stature, skin), clothes, hair.

Skin tones are linear albedos spanning the range seen in German cities (light European to dark
African skin); the shape targets' race shares follow the tone. Colours of the clothes here are
the model's own; the render draws each object's clothes (top, bottom, shoes) in colours of its
own (``synthcompose/look/appearance.py``); skin, hair, eyebrows and an inner layer keep these.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from .body import Garment

#: linear albedo of skin tones, light to dark
SKIN = {
    "light": (0.56, 0.39, 0.31),
    "fair": (0.50, 0.34, 0.25),
    "medium": (0.41, 0.26, 0.175),
    "olive": (0.32, 0.20, 0.125),
    "brown": (0.19, 0.11, 0.068),
    "dark": (0.095, 0.055, 0.036),
}
#: linear albedo of hair colours
HAIR = {
    "black": (0.018, 0.015, 0.013),
    "dark-brown": (0.045, 0.028, 0.018),
    "brown": (0.085, 0.052, 0.030),
    "light-brown": (0.16, 0.10, 0.055),
    "blonde": (0.32, 0.23, 0.12),
    "grey": (0.24, 0.235, 0.225),
    "white": (0.42, 0.41, 0.39),
}
#: linear albedo of the model's own clothes colours (the render recolours top, bottom, shoes)
CLOTHES = {
    "navy": (0.025, 0.035, 0.08), "denim": (0.05, 0.08, 0.16), "black": (0.022, 0.022, 0.024),
    "grey": (0.13, 0.13, 0.13), "white": (0.60, 0.60, 0.58), "beige": (0.32, 0.26, 0.17),
    "olive": (0.07, 0.08, 0.035), "brown": (0.09, 0.05, 0.028), "light-blue": (0.35, 0.42, 0.55),
    "burgundy": (0.16, 0.025, 0.035),
}
A = "base/clothes/"


def outfit(name: str, **kw) -> Garment:
    return Garment(f"{A}{name}/{name}", "clothes", **kw)


def shoes(name: str) -> Garment:
    return Garment(f"{A}{name}/{name}", "shoes")


def hair(name: str) -> Garment:
    return Garment(f"base/hair/{name}/{name}", "hair")


def brows(name: str) -> Garment:
    return Garment(f"base/eyebrows/{name}/{name}", "eyebrows")


@dataclass
class Person:
    """One person to build. ``age`` in years; ``muscle``, ``weight`` MakeHuman's macro values
    (0..1, 0.5 average); ``stature`` metres barefoot; ``colours``: the model's own colour of each
    clothes material (names of :data:`CLOTHES`)."""

    id: str
    sex: str
    age: float
    build: str
    stature: float
    skin: str
    races: dict
    muscle: float
    weight: float
    hair_name: str
    hair_colour: str
    clothes: str  # words for the record: what the outfit is
    garments: list = field(default_factory=list)
    colours: dict = field(default_factory=dict)

    @property
    def age_group(self) -> str:
        return "teen" if self.age < 20 else "elderly" if self.age >= 65 else "adult"

    def macro(self) -> dict[str, float]:
        """MakeHuman's macro values: age 1 / 11 / 25 / 90 years at 0 / 0.1875 / 0.5 / 1."""
        a = self.age
        age = a / 11 * 0.1875 if a < 11 else 0.1875 + (a - 11) / 14 * 0.3125 if a < 25 else 0.5 + (a - 25) / 65 * 0.5
        return {"gender": 1.0 if self.sex == "male" else 0.0, "age": min(age, 1.0), "muscle": self.muscle,
                "weight": self.weight, "height": 0.5, "proportions": 0.5}


PEOPLE = [
    Person("man-jacket", "male", 38, "average", 1.80, "fair", {"caucasian": 1.0}, 0.55, 0.5,
           "short", "dark-brown", "jacket over a shirt, jeans, black shoes",
           [outfit("male_casualsuit05", inner=(0, 1, 15, 16, 17, 18)), shoes("shoes03"), hair("short02"),
            brows("eyebrow001")], {"clothes_top": "olive", "clothes_inner": "burgundy", "clothes_bottom": "denim",
                                   "shoes": "black"}),
    Person("man-shirt-heavy", "male", 47, "heavy", 1.76, "olive", {"caucasian": 1.0}, 0.5, 0.78,
           "short", "black", "long-sleeved shirt, jeans, brown shoes",
           [outfit("male_casualsuit01"), shoes("shoes01"), hair("short04"), brows("eyebrow004")],
           {"clothes_top": "light-blue", "clothes_bottom": "denim", "shoes": "brown"}),
    Person("man-elderly-suit", "male", 73, "average", 1.73, "light", {"caucasian": 1.0}, 0.4, 0.6,
           "short", "grey", "suit jacket, shirt and tie, trousers, black shoes",
           [outfit("male_elegantsuit01", inner=(3, 6, 17, 18, 19, 20)), shoes("shoes03"), hair("short03"),
            brows("eyebrow010")], {"clothes_top": "grey", "clothes_inner": "white", "clothes_bottom": "grey",
                                   "shoes": "black"}),
    Person("boy-teen", "male", 16, "slim", 1.74, "fair", {"caucasian": 1.0}, 0.45, 0.35,
           "short", "light-brown", "t-shirt, jeans, trainers",
           [outfit("male_casualsuit04"), shoes("shoes06"), hair("short01"), brows("eyebrow007")],
           {"clothes_top": "navy", "clothes_bottom": "denim", "shoes": "navy"}),
    Person("man-young-dark", "male", 27, "athletic", 1.84, "dark", {"african": 1.0}, 0.7, 0.5,
           "short", "black", "t-shirt, jeans, white trainers",
           [outfit("male_casualsuit06"), shoes("shoes05"), hair("short04"), brows("eyebrow002")],
           {"clothes_top": "white", "clothes_bottom": "black", "shoes": "white"}),
    Person("man-striped", "male", 31, "slim", 1.77, "medium", {"asian": 0.7, "caucasian": 0.3}, 0.5, 0.4,
           "short", "black", "shirt, jeans, trainers",
           [outfit("male_casualsuit03"), shoes("shoes02"), hair("short02"), brows("eyebrow003")],
           {"clothes_top": "burgundy", "clothes_bottom": "denim", "shoes": "grey"}),
    Person("woman-casual", "female", 30, "slim", 1.68, "fair", {"caucasian": 1.0}, 0.45, 0.4,
           "ponytail", "brown", "t-shirt, jeans, white trainers",
           [outfit("female_casualsuit01"), shoes("shoes05"), hair("ponytail01"), brows("eyebrow005")],
           {"clothes_top": "navy", "clothes_bottom": "denim", "shoes": "white"}),
    Person("woman-elderly", "female", 74, "heavy", 1.61, "light", {"caucasian": 1.0}, 0.4, 0.72,
           "bob", "white", "jacket over a blouse, skirt, brown shoes",
           [outfit("female_elegantsuit01", inner=(1, 2)), shoes("shoes04"), hair("bob02"), brows("eyebrow006")],
           {"clothes_top": "beige", "clothes_inner": "white", "clothes_bottom": "brown", "shoes": "brown"}),
    Person("girl-teen", "female", 15, "slim", 1.63, "olive", {"caucasian": 0.8, "african": 0.2}, 0.45, 0.4,
           "long", "black", "t-shirt, denim shorts, trainers",
           [outfit("female_casualsuit02"), shoes("shoes06"), hair("long01"), brows("eyebrow008")],
           {"clothes_top": "white", "clothes_bottom": "denim", "shoes": "navy"}),
    Person("woman-brown", "female", 36, "average", 1.70, "brown", {"african": 0.8, "caucasian": 0.2}, 0.5, 0.55,
           "bob", "black", "jacket, skirt, black shoes",
           [outfit("female_elegantsuit01", inner=(1, 2)), shoes("shoes03"), hair("bob01"), brows("eyebrow005")],
           {"clothes_top": "black", "clothes_inner": "white", "clothes_bottom": "grey", "shoes": "black"}),
    Person("woman-asian", "female", 27, "slim", 1.60, "light", {"asian": 1.0}, 0.45, 0.4,
           "long", "black", "top, leggings, trainers",
           [outfit("female_sportsuit01"), shoes("shoes02"), hair("braid01"), brows("eyebrow011")],
           {"clothes_top": "grey", "clothes_bottom": "black", "shoes": "white"}),
    Person("man-casual", "male", 24, "average", 1.82, "light", {"caucasian": 1.0}, 0.5, 0.5,
           "short", "blonde", "long-sleeved top, jeans, brown shoes",
           [outfit("male_casualsuit02"), shoes("shoes04"), hair("short01"), brows("eyebrow009")],
           {"clothes_top": "grey", "clothes_bottom": "denim", "shoes": "brown"}),
]
