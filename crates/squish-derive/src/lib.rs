//! `#[derive(Params)]`: one declaration of a parameter struct gives everything else.
//!
//! A struct of user-facing parameters (Squish's `ObjectParams`, `PairParams`,
//! `ArticulationParams`, the scene file's top-level settings) is declared once, with a doc comment
//! and a `#[param(…)]` attribute on every field. The derive writes from it:
//! - `Params::schema()`: one `ParamInfo` per parameter — key, level, kind (from the field's type),
//!   unit, valid range, thesis symbol and section, the doc comment's first paragraph as the
//!   one-line meaning, whether it can be keyframed, how an `auto` value is derived, the names it
//!   had before (for "did you mean" messages);
//! - `Params::get` / `Params::set_field`: typed access by key, used by every entry point (the
//!   command line's `--set`, parameter and scene files, report.json, the bindings);
//! - `serde::Serialize` / `Deserialize` as a map of the parameters' values.
//!
//! The struct's `Default` is written by hand (defaults are values, not attributes); the schema reads
//! them from it, so a default is declared in exactly one place too.
//!
//! Struct attribute: `#[params(level = Object, table = "frames", check = method)]` — the level of
//! its keys, the table of a file that holds them (for keys shown as `frames.start`; none for the
//! deformer's parameters, whose tables are the objects and pairs themselves), and an optional
//! inherent method `fn(&self) -> Result<(), ParamError>` checking conditions between fields (run
//! by `Params::validate` after the per-key ranges).
//!
//! Field attribute: `#[param(skip)]` for a field that is not a user parameter (data the caller
//! fills in, such as per-vertex UVs), or any of
//! `symbol = "k"`, `section = "§4.3"`, `unit = "scene units"`, `range = "(0, inf)"` (interval
//! notation; `inf` may be included with `]`; default: any finite number), `keyframable`,
//! `word = "auto"` (how `None` is written for an `Option` field; default `auto`),
//! `auto = "…"` (how that value is derived), `key = "…"` (default: the field's name), `required`
//! (no default: a file must give it),
//! `renamed_from = "old, older"`; a bare `#[param]` for a parameter with nothing more to say.
//! Every field needs one of these, so that adding a field is always a decision about whether users
//! see it.

use proc_macro::TokenStream;
use proc_macro2::TokenStream as Tokens;
use quote::quote;
use syn::{Data, DeriveInput, Fields, LitStr, parse_macro_input};

#[proc_macro_derive(Params, attributes(params, param))]
pub fn derive_params(input: TokenStream) -> TokenStream {
    let input = parse_macro_input!(input as DeriveInput);
    match expand(&input) {
        Ok(tokens) => tokens.into(),
        Err(e) => e.to_compile_error().into(),
    }
}

/// What `#[param(…)]` says about a field.
#[derive(Default)]
struct FieldAttrs {
    skip: bool,
    required: bool,
    key: Option<String>,
    symbol: String,
    section: String,
    unit: String,
    range: Option<(f64, bool, f64, bool)>,
    keyframable: bool,
    word: Option<String>,
    auto: String,
    renamed_from: Vec<String>,
}

fn expand(input: &DeriveInput) -> syn::Result<Tokens> {
    let name = &input.ident;
    let mut level: Option<syn::Ident> = None;
    let mut check: Option<syn::Ident> = None;
    let mut table = String::new();
    for attr in input.attrs.iter().filter(|a| a.path().is_ident("params")) {
        attr.parse_nested_meta(|meta| {
            if meta.path.is_ident("level") {
                level = Some(meta.value()?.parse()?);
            } else if meta.path.is_ident("check") {
                check = Some(meta.value()?.parse()?);
            } else if meta.path.is_ident("table") {
                table = meta.value()?.parse::<LitStr>()?.value();
            } else {
                return Err(meta.error("expected `level = …`, `table = \"…\"` or `check = …`"));
            }
            Ok(())
        })?;
    }
    let level = level.ok_or_else(|| syn::Error::new_spanned(name, "add #[params(level = Object)] (or Pair, …)"))?;
    let Data::Struct(data) = &input.data else {
        return Err(syn::Error::new_spanned(name, "Params derives only on structs"));
    };
    let Fields::Named(fields) = &data.fields else {
        return Err(syn::Error::new_spanned(name, "Params needs named fields"));
    };

    let krate = quote!(::squish::params);
    let mut infos = Vec::new();
    let mut get_arms = Vec::new();
    let mut set_arms = Vec::new();
    let mut index = 0usize;
    for field in &fields.named {
        let ident = field.ident.as_ref().ok_or_else(|| syn::Error::new_spanned(field, "unnamed field"))?;
        let attrs = field_attrs(field)?;
        if attrs.skip {
            continue;
        }
        let ty = &field.ty;
        let key = attrs.key.clone().unwrap_or_else(|| ident.to_string());
        let (summary, doc) = doc_text(field);
        if summary.is_empty() {
            return Err(syn::Error::new_spanned(
                ident,
                "document the parameter: its doc comment is its one-line meaning",
            ));
        }
        let FieldAttrs { symbol, section, unit, keyframable, required, auto, renamed_from, .. } = &attrs;
        let word = attrs.word.clone().unwrap_or_else(|| "auto".to_string());
        let (min, min_inclusive, max, max_inclusive) =
            attrs.range.unwrap_or((f64::NEG_INFINITY, false, f64::INFINITY, false));
        let min = float_tokens(min);
        let max = float_tokens(max);
        infos.push(quote! {
            #krate::ParamInfo {
                key: #key,
                table: #table,
                level: #krate::Level::#level,
                kind: <#ty as #krate::ParamType>::KIND,
                optional: <#ty as #krate::ParamType>::OPTIONAL,
                word: #word,
                unit: #unit,
                range: #krate::Range { min: #min, min_inclusive: #min_inclusive, max: #max, max_inclusive: #max_inclusive },
                symbol: #symbol,
                section: #section,
                summary: #summary,
                doc: #doc,
                auto: #auto,
                keyframable: #keyframable,
                required: #required,
                renamed_from: &[#(#renamed_from),*],
            }
        });
        get_arms.push(quote! {
            #key => ::core::option::Option::Some(#krate::ParamType::to_value(&self.#ident, &schema[#index])),
        });
        set_arms.push(quote! {
            #key => {
                self.#ident = #krate::ParamType::from_value(value, &schema[#index])?;
                ::core::result::Result::Ok(true)
            }
        });
        index += 1;
    }
    let count = index;
    let check_body = match &check {
        Some(method) => quote!(Self::#method(self)),
        None => quote!(::core::result::Result::Ok(())),
    };
    Ok(quote! {
        impl #krate::Params for #name {
            const LEVEL: #krate::Level = #krate::Level::#level;

            fn schema() -> &'static [#krate::ParamInfo] {
                static SCHEMA: [#krate::ParamInfo; #count] = [#(#infos),*];
                &SCHEMA
            }

            fn get(&self, key: &str) -> ::core::option::Option<#krate::ParamValue> {
                let schema = <Self as #krate::Params>::schema();
                match key {
                    #(#get_arms)*
                    _ => ::core::option::Option::None,
                }
            }

            fn set_field(&mut self, key: &str, value: &#krate::ParamValue) -> ::core::result::Result<bool, ::std::string::String> {
                let schema = <Self as #krate::Params>::schema();
                match key {
                    #(#set_arms)*
                    _ => ::core::result::Result::Ok(false),
                }
            }

            fn check_fields(&self) -> ::core::result::Result<(), #krate::ParamError> {
                #check_body
            }
        }

        impl ::serde::Serialize for #name {
            fn serialize<S: ::serde::Serializer>(&self, serializer: S) -> ::core::result::Result<S::Ok, S::Error> {
                #krate::serialize_params(self, serializer)
            }
        }

        impl<'de> ::serde::Deserialize<'de> for #name {
            fn deserialize<D: ::serde::Deserializer<'de>>(deserializer: D) -> ::core::result::Result<Self, D::Error> {
                #krate::deserialize_params(deserializer)
            }
        }
    })
}

fn field_attrs(field: &syn::Field) -> syn::Result<FieldAttrs> {
    let mut out = FieldAttrs::default();
    let mut seen = false;
    for attr in field.attrs.iter().filter(|a| a.path().is_ident("param")) {
        seen = true;
        if matches!(attr.meta, syn::Meta::Path(_)) {
            continue;
        }
        attr.parse_nested_meta(|meta| {
            let string = |meta: &syn::meta::ParseNestedMeta| -> syn::Result<String> {
                Ok(meta.value()?.parse::<LitStr>()?.value())
            };
            let path = &meta.path;
            if path.is_ident("skip") {
                out.skip = true;
            } else if path.is_ident("keyframable") {
                out.keyframable = true;
            } else if path.is_ident("required") {
                out.required = true;
            } else if path.is_ident("key") {
                out.key = Some(string(&meta)?);
            } else if path.is_ident("symbol") {
                out.symbol = string(&meta)?;
            } else if path.is_ident("section") {
                out.section = string(&meta)?;
            } else if path.is_ident("unit") {
                out.unit = string(&meta)?;
            } else if path.is_ident("word") {
                out.word = Some(string(&meta)?);
            } else if path.is_ident("auto") {
                out.auto = string(&meta)?;
            } else if path.is_ident("renamed_from") {
                out.renamed_from = string(&meta)?.split(',').map(|s| s.trim().to_string()).collect();
            } else if path.is_ident("range") {
                let lit: LitStr = meta.value()?.parse()?;
                out.range = Some(parse_range(&lit.value()).map_err(|m| syn::Error::new_spanned(&lit, m))?);
            } else {
                return Err(meta.error("unknown #[param] key"));
            }
            Ok(())
        })?;
    }
    if !seen {
        return Err(syn::Error::new_spanned(
            field,
            "every field needs #[param] or #[param(…)] (a user parameter) or #[param(skip)] (data that is not one)",
        ));
    }
    Ok(out)
}

/// `"(0, inf)"`, `"[1, inf]"`, `"(0, 90]"`, `"[-1, inf)"` → (min, min inclusive, max, max inclusive).
fn parse_range(text: &str) -> Result<(f64, bool, f64, bool), String> {
    let text = text.trim();
    let bad = || format!("range \"{text}\": write an interval such as \"(0, inf)\", \"[0, 1]\" or \"[1, inf]\"");
    let open = text.chars().next().ok_or_else(bad)?;
    let close = text.chars().last().ok_or_else(bad)?;
    let inner = text.get(1..text.len() - 1).ok_or_else(bad)?;
    let (lo, hi) = inner.split_once(',').ok_or_else(bad)?;
    let number = |s: &str| -> Result<f64, String> {
        match s.trim() {
            "inf" => Ok(f64::INFINITY),
            "-inf" => Ok(f64::NEG_INFINITY),
            s => s.parse::<f64>().map_err(|_| bad()),
        }
    };
    let min_inclusive = match open {
        '[' => true,
        '(' => false,
        _ => return Err(bad()),
    };
    let max_inclusive = match close {
        ']' => true,
        ')' => false,
        _ => return Err(bad()),
    };
    Ok((number(lo)?, min_inclusive, number(hi)?, max_inclusive))
}

fn float_tokens(x: f64) -> Tokens {
    if x == f64::INFINITY {
        quote!(f64::INFINITY)
    } else if x == f64::NEG_INFINITY {
        quote!(f64::NEG_INFINITY)
    } else {
        quote!(#x)
    }
}

/// The doc comment as (first paragraph on one line, whole text).
fn doc_text(field: &syn::Field) -> (String, String) {
    let mut lines = Vec::new();
    for attr in &field.attrs {
        if attr.path().is_ident("doc")
            && let syn::Meta::NameValue(nv) = &attr.meta
            && let syn::Expr::Lit(syn::ExprLit { lit: syn::Lit::Str(s), .. }) = &nv.value
        {
            lines.push(s.value().trim().to_string());
        }
    }
    let summary = lines.iter().take_while(|l| !l.is_empty()).cloned().collect::<Vec<_>>().join(" ");
    let mut doc = String::new();
    for line in &lines {
        if line.is_empty() {
            doc.push_str("\n\n");
        } else {
            if !(doc.is_empty() || doc.ends_with('\n')) {
                doc.push(' ');
            }
            doc.push_str(line);
        }
    }
    (summary, doc.trim().to_string())
}
